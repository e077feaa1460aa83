// IPSVI's GPU twin, the merge of a line's writes into the cache (cpu::merge), in three
// kernels run after every trace dispatch (see ipsvi_cache.wgsl for why it is exact):
// `arguments` sizes the next two from the counters (indirect dispatches: no readback per
// line), `merge` lowers each texel's lo, and after a line's last trace dispatch `commit`
// moves each touched texel's least entry into the cache.

//#include "ipsvi_cache.wgsl"

// Invocations per workgroup of `merge` and `commit`.
const WORKGROUP: u32 = 256u;
// Workgroups per dimension every adapter allows; `merge` and `commit` stride over the rest.
const MAX_GROUPS: u32 = 65535u;

// Indirect dispatch arguments: `merge`'s workgroups (x, y, z), then `commit`'s.
@group(0) @binding(0) var<storage, read_write> dispatch: array<u32, 6>;
// Writes in the list and touched texels, as `arguments` found them.
@group(0) @binding(1) var<storage, read_write> sizes: array<u32, 2>;

// Workgroups for n items (at least one item each, the rest strided).
fn groups_for(n: u32) -> u32 {
    return min((n + WORKGROUP - 1u) / WORKGROUP, MAX_GROUPS);
}

// One invocation: takes the counts, empties the write list for the next trace dispatch and
// writes the dispatch arguments.
@compute @workgroup_size(1, 1, 1)
fn arguments() {
    let listed = atomicLoad(&counters[WRITES]);
    let capacity = arrayLength(&writes);
    if (listed > capacity) {
        atomicStore(&counters[OVERFLOW], 1u);
    }
    let written = min(listed, capacity);
    let texels = atomicLoad(&counters[TOUCHED]);
    atomicStore(&counters[WRITES], 0u);
    sizes[0] = written;
    sizes[1] = texels;
    dispatch[0] = groups_for(written);
    dispatch[1] = 1u;
    dispatch[2] = 1u;
    dispatch[3] = groups_for(texels);
    dispatch[4] = 1u;
    dispatch[5] = 1u;
}

// Each listed write whose hi is its texel's least lowers the texel's lo.
@compute @workgroup_size(256, 1, 1)
fn merge(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    for (var i = id.x; i < sizes[0]; i = i + groups.x * WORKGROUP) {
        let w = writes[i];
        if (w.hi == atomicLoad(&line_first[2u * w.texel])) {
            atomicMin(&line_first[2u * w.texel + 1u], w.lo);
        }
    }
}

// The end of a line: each touched texel keeps the greater of its entry and the line's least
// (the only entry that every later sample on its ray can start from), and its line_first
// and the touched list are emptied for the next line.
@compute @workgroup_size(256, 1, 1)
fn commit(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    if (id.x == 0u) {
        atomicStore(&counters[TOUCHED], 0u);
    }
    for (var i = id.x; i < sizes[1]; i = i + groups.x * WORKGROUP) {
        let texel = touched[i];
        let first = vec2<u32>(
            atomicLoad(&line_first[2u * texel]),
            atomicLoad(&line_first[2u * texel + 1u]),
        );
        if (entry_less(cache[texel], first)) {
            cache[texel] = first;
        }
        atomicStore(&line_first[2u * texel], NONE);
        atomicStore(&line_first[2u * texel + 1u], NONE);
    }
}

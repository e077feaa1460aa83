// IPSVI's illumination cache on the GPU and the lists a line's writes go through, shared by
// the trace (ipsvi.wgsl) and the merge (ipsvi_merge.wgsl); src/render/ipsvi/gpu.rs binds them.
//
// An entry is cache::Entry::pack's u64 as (hi, lo): hi the order-preserving bits of s, lo the
// bits of tau; comparing (hi, lo) lexicographically is the CPU's u64 order, and (0, 0) is EMPTY.
//
// The merge (cpu::merge: per written texel the line's least entry, then the cache keeps the
// greater of it and its own) without 64-bit atomics, deterministic whatever the threads do:
// - a write (record_write, during the trace) goes to the write list and lowers the texel's
//   `line_first` hi by atomicMin; whoever lowers it empties the texel's lo (the lo of a larger
//   hi is no longer the least); whoever finds hi at NONE lists the texel as touched;
// - then (merge) every listed write whose hi equals the texel's lowers its lo by atomicMin.
// After both, (hi, lo) is the least entry written so far in the line, even when the line's
// pixels were traced in several dispatches with the write list emptied between them (a later
// dispatch only lowers hi, emptying lo, or adds to lo at an unchanged hi). At the end of the
// line (commit) each touched texel's cache entry becomes the greater of it and (hi, lo), and
// `line_first` returns to NONE.

// No entry in `line_first` (above every entry: s is finite, so hi < NONE).
const NONE: u32 = 0xffffffffu;

// Indices in `counters`.
const WRITES: u32 = 0u;
const TOUCHED: u32 = 1u;
// Non-zero when the write list overflowed (a bug: gpu.rs sizes it for the longest rays).
const OVERFLOW: u32 = 2u;

// One entry a view ray left behind in a texel (cpu.rs's `writes`).
struct Write {
    texel: u32,
    hi: u32,
    lo: u32,
};

// The cache: one entry per texel, read by the trace as the previous lines left it.
@group(0) @binding(10) var<storage, read_write> cache: array<vec2<u32>>;
// The writes of the dispatch being merged.
@group(0) @binding(11) var<storage, read_write> writes: array<Write>;
@group(0) @binding(12) var<storage, read_write> counters: array<atomic<u32>, 3>;
// Per texel (hi, lo): the least entry written in the line so far, NONE when none.
@group(0) @binding(13) var<storage, read_write> line_first: array<atomic<u32>>;
// The texels written in the line, each once.
@group(0) @binding(14) var<storage, read_write> touched: array<u32>;

// Whether entry a comes before b in the CPU's u64 order.
fn entry_less(a: vec2<u32>, b: vec2<u32>) -> bool {
    return a.x < b.x || (a.x == b.x && a.y < b.y);
}

// cache::Entry::pack of (s, tau): s's sign-magnitude bits made monotonic as an unsigned integer.
fn pack_entry(s: f32, tau: f32) -> vec2<u32> {
    let bits = bitcast<u32>(s);
    var ordered = bits | 0x80000000u;
    if ((bits >> 31u) == 1u) {
        ordered = ~bits;
    }
    return vec2<u32>(ordered, bitcast<u32>(max(tau, 0.0)));
}

// (s, tau) of a packed entry that is not EMPTY (cache::Entry::unpack).
fn unpack_entry(packed: vec2<u32>) -> vec2<f32> {
    var bits = ~packed.x;
    if ((packed.x >> 31u) == 1u) {
        bits = packed.x & 0x7fffffffu;
    }
    return vec2<f32>(bitcast<f32>(bits), bitcast<f32>(packed.y));
}

// Whether a cache entry is EMPTY.
fn is_empty(packed: vec2<u32>) -> bool {
    return packed.x == 0u && packed.y == 0u;
}

// Hands one write to the merge: listed, and its hi merged into the line's least (see above).
fn record_write(texel: u32, entry: vec2<u32>) {
    let index = atomicAdd(&counters[WRITES], 1u);
    if (index < arrayLength(&writes)) {
        writes[index] = Write(texel, entry.x, entry.y);
    }
    let old = atomicMin(&line_first[2u * texel], entry.x);
    if (old == NONE) {
        touched[atomicAdd(&counters[TOUCHED], 1u)] = texel;
    }
    if (entry.x < old) {
        atomicStore(&line_first[2u * texel + 1u], NONE);
    }
}

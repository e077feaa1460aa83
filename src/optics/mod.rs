//! The optical model every method and every reference shares (docs/architecture.md#optical-model):
//! the classified volume as a participating medium ([`medium`]), its phase functions
//! ([`phase`]), the majorant grid that lets a path tracer sample it ([`majorants`]) and the
//! occupancy grid that lets a ray skip its empty space ([`occupancy`]). It sits below the
//! methods: the renderers, the AO references and the planner read it, none owns it.

pub mod majorants;
pub mod medium;
pub mod occupancy;
pub mod phase;

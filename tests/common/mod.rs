//! Helpers shared by integration tests. Each test binary compiles its own copy and uses a
//! subset, hence the allowance.
#![allow(dead_code)]

pub mod quadrature;
pub mod twins;

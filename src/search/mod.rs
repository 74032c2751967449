//! (being built)

pub mod gp;

//! Name resolution, type checking and lowering to the Domain IR (being built).
pub mod diagnostic;

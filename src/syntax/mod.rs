//! `.rev` text → syntax tree. [`parser::parse`] never fails: syntax errors become error nodes
//! plus diagnostics, so a file with several mistakes reports each one and later stages still see
//! the rest of the file.
pub mod ast;
pub mod parser;

pub use parser::{Parsed, parse};

//! `.rev` text → syntax tree. [`parser::parse`] never fails: syntax errors become error nodes
//! plus diagnostics, so a file with several mistakes reports each one and later stages still see
//! the rest of the file. [`lexer`] is the lossless token layer beside it (comments, blank lines,
//! token classes), [`grammar`] the pest grammar both walk.
pub mod ast;
pub mod grammar;
pub mod lexer;
pub mod parser;

pub use parser::{Parsed, parse};

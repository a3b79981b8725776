//! The spec language: syntax tree and the one parser shared by the macro and the CLI.

pub mod ast;
pub mod expand;
pub mod parse;
pub mod rules;
pub mod scan;

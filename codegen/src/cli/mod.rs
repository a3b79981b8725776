//! The closed-loop side of the command line: compiling a spec's generated code for the runner
//! ([`jit`]), single runs ([`sim`]) and Monte-Carlo sweeps ([`sweep`]).

pub mod bench;
pub mod jit;
pub mod sim;
pub mod sweep;

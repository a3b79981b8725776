//! Parse, check and lower (range analysis, Q-formats, shift-add) on arbitrary text: a plan or
//! an error, never a panic (every debug assertion of the lowering is on: a value whose
//! proved interval does not fit its type, a shift as wide as its operand), a stack overflow
//! or a hang.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(src) = std::str::from_utf8(data) {
        let _ = qloop::compile_str(src, &qloop::Target::default());
    }
});

//! The spec parser on arbitrary text: it returns a spec or an error, and never panics, overflows
//! the stack or hangs. (Under `cfg(fuzzing)` proc-macro2 keeps no line/column information, so
//! that errors are located is tested by the proptests and `tests/tests/claims.rs` instead.)
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(src) = std::str::from_utf8(data) {
        let _ = qloop::lang::parse::parse_str(src);
    }
});

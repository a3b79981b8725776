//! The whole pipeline on arbitrary text: every spec that compiles goes through every emitter
//! (Rust, f64 reference, Kani harnesses, C, LinuxCNC, the SMT obligations, the check report)
//! and, for specs without user claims, one step of the plan interpreter from its initial state
//! on corner inputs, which checks every value against its proved interval. Nothing may panic,
//! overflow the stack or hang.
#![no_main]

use libfuzzer_sys::fuzz_target;
use qloop::ir::SigKind;

fuzz_target!(|data: &[u8]| {
    let Ok(src) = std::str::from_utf8(data) else {
        return;
    };
    for target in ["rv32i", "atmega328p"] {
        let Some(t) = qloop::targets::by_name(target) else {
            return;
        };
        let Ok(plan) = qloop::compile_str(src, &t) else {
            return;
        };
        let _ = qloop::gen_rust(&plan);
        let _ = qloop::gen_reference(&plan);
        let _ = qloop::gen_kani(&plan);
        let _ = qloop::gen_c(&plan);
        let _ = qloop::gen_linuxcnc(&plan);
        let _ = qloop::report::check_report(&plan, "fuzz.qloop");
        let _ = qloop::prove::obligations::obligations(&plan);
        // A `#[range]` or `#[unsaturated]` claim may be false (the prover refutes it, see
        // tests/fixtures/refute); without one, every value must stay in its proved interval.
        let claims = plan
            .prog
            .signals
            .iter()
            .any(|s| s.claim.is_some() || s.unsaturated);
        for corner in [0usize, 1, 2].into_iter().filter(|_| !claims) {
            let mut vars = vec![0i128; plan.prog.signals.len()];
            for (i, s) in plan.prog.signals.iter().enumerate() {
                let id = qloop::ir::SigId(i);
                vars[i] = match s.kind {
                    SigKind::Input => {
                        let ty = plan.format(id).ty;
                        [ty.min(), 0, ty.max().min(i64::MAX as i128)][corner]
                    }
                    SigKind::State => plan.raw_init(id),
                    _ => 0,
                };
            }
            if let Err(v) = qloop::interp::step_fixed(&plan, &mut vars) {
                panic!("a value left its proved interval: {v:?}");
            }
        }
    }
});

//! The plan interpreter and the real-arithmetic interpreter as closed-loop controllers.
//!
//! `qloop sim` and `sweep` compile the generated Rust and run it, so that a run shows the real
//! routine. `qloop tune` scores hundreds of candidate specs, and compiling each with rustc
//! would take seconds; it runs [`Interpreted`] instead: [`crate::interp::step_fixed`], the
//! executable definition of the generated code's semantics, which the emitted Rust, C and SMT
//! match bit for bit (tests `c_output`, `smt_differential`, `interpreted_matches_compiled`),
//! beside [`RealInterpreted`], the f64 reference ([`crate::interp::step_real`]).

use crate::interp::{step_fixed, step_real, RangeViolation};
use crate::ir::{SigId, SigKind};
use crate::Plan;
use qloop_plant::controller::{from_bits, to_bits};
use qloop_plant::{Controller, Signals};
use std::cell::RefCell;
use std::collections::HashSet;
use std::rc::Rc;
use std::sync::{Mutex, OnceLock};

/// `s` as a `&'static str`, stored once per distinct text ([`Signals`] holds static names; a
/// tuning run makes many controllers with the same few names).
fn intern(s: &str) -> &'static str {
    static SEEN: OnceLock<Mutex<HashSet<&'static str>>> = OnceLock::new();
    let mut seen = SEEN
        .get_or_init(Default::default)
        .lock()
        .unwrap_or_else(|p| p.into_inner());
    if let Some(t) = seen.get(s) {
        return t;
    }
    let t: &'static str = Box::leak(s.to_string().into_boxed_str());
    seen.insert(t);
    t
}

/// The signal ids of each kind, in declaration order, and their [`Signals`].
fn tables(plan: &Plan) -> ([Vec<SigId>; 3], Signals) {
    let prog = &plan.prog;
    let ids = |k| prog.ids_of(k).collect::<Vec<_>>();
    let ids = [
        ids(SigKind::Input),
        ids(SigKind::State),
        ids(SigKind::Output),
    ];
    let named = |v: &[SigId]| {
        v.iter()
            .map(|id| {
                let s = prog.sig(*id);
                (intern(&s.label()), intern(s.unit.as_deref().unwrap_or("")))
            })
            .collect()
    };
    let sig = Signals {
        inputs: named(&ids[0]),
        states: named(&ids[1]),
        outputs: named(&ids[2]),
    };
    (ids, sig)
}

/// The fixed-point plan, run by the interpreter: the generated `step_bits` semantics (an
/// input is rounded to its format and saturated to its storage type, as the generated code's
/// glue does; the plan then clamps it to its declared range).
pub struct Interpreted {
    plan: Rc<Plan>,
    ids: [Vec<SigId>; 3],
    signals: Signals,
    vars: Vec<i128>,
    /// The step's working copy of `vars` (kept, so that a step does not allocate).
    next: Vec<i128>,
    violation: Violations,
}

/// Where an [`Interpreted`] controller records the first value that left the interval the
/// range analysis proved for it (a bug in qloop); shared, so that it can be read after the
/// controller has been handed to a runner.
#[derive(Clone, Debug, Default)]
pub struct Violations(Rc<RefCell<Option<RangeViolation>>>);

impl Violations {
    /// The first violation, if any.
    pub fn first(&self) -> Option<RangeViolation> {
        self.0.borrow().clone()
    }
}

impl Interpreted {
    /// A controller in its initial state.
    pub fn new(plan: Rc<Plan>) -> Interpreted {
        let (ids, signals) = tables(&plan);
        let mut vars = vec![0i128; plan.prog.signals.len()];
        for id in &ids[1] {
            vars[id.0] = plan.raw_init(*id);
        }
        Interpreted {
            plan,
            ids,
            signals,
            next: vars.clone(),
            vars,
            violation: Violations::default(),
        }
    }

    /// Its violation record: the first value that left the interval the range analysis proved
    /// for it, if any (a bug in qloop; the step that found it kept its states).
    pub fn violations(&self) -> Violations {
        self.violation.clone()
    }
}

impl Controller for Interpreted {
    fn signals(&self) -> Signals {
        self.signals.clone()
    }

    fn period(&self) -> f64 {
        self.plan.prog.period
    }

    fn step(&mut self, inputs: &[f64], outputs: &mut [f64]) {
        for (id, v) in self.ids[0].iter().zip(inputs) {
            let f = self.plan.format(*id);
            self.vars[id.0] = i128::from(to_bits(*v, f.frac)).clamp(f.ty.min(), f.ty.max());
        }
        self.next.copy_from_slice(&self.vars);
        match step_fixed(&self.plan, &mut self.next) {
            Ok(_) => std::mem::swap(&mut self.vars, &mut self.next),
            Err(v) => {
                self.violation.0.borrow_mut().get_or_insert(v);
            }
        }
        for (id, y) in self.ids[2].iter().zip(outputs.iter_mut()) {
            *y = raw_value(&self.plan, *id, self.vars[id.0]);
        }
    }

    fn states(&self, out: &mut [f64]) {
        for (id, y) in self.ids[1].iter().zip(out.iter_mut()) {
            *y = raw_value(&self.plan, *id, self.vars[id.0]);
        }
    }
}

/// The physical value of a signal's raw integer.
fn raw_value(plan: &Plan, id: SigId, raw: i128) -> f64 {
    // Every storage type is at most 64 bits wide.
    from_bits(
        raw.clamp(i64::MIN.into(), i64::MAX.into()) as i64,
        plan.format(id).frac,
    )
}

/// The spec in real arithmetic ([`step_real`]): what the generated f64 reference computes.
pub struct RealInterpreted {
    plan: Rc<Plan>,
    ids: [Vec<SigId>; 3],
    signals: Signals,
    vars: Vec<f64>,
}

impl RealInterpreted {
    /// A controller in its initial state.
    pub fn new(plan: Rc<Plan>) -> RealInterpreted {
        let (ids, signals) = tables(&plan);
        let mut vars = vec![0.0; plan.prog.signals.len()];
        for id in &ids[1] {
            vars[id.0] = plan.prog.sig(*id).init.unwrap_or(0.0);
        }
        RealInterpreted {
            plan,
            ids,
            signals,
            vars,
        }
    }
}

impl Controller for RealInterpreted {
    fn signals(&self) -> Signals {
        self.signals.clone()
    }

    fn period(&self) -> f64 {
        self.plan.prog.period
    }

    fn step(&mut self, inputs: &[f64], outputs: &mut [f64]) {
        for (id, v) in self.ids[0].iter().zip(inputs) {
            self.vars[id.0] = *v;
        }
        step_real(&self.plan.prog, &mut self.vars);
        for (id, y) in self.ids[2].iter().zip(outputs.iter_mut()) {
            *y = self.vars[id.0];
        }
    }

    fn states(&self, out: &mut [f64]) {
        for (id, y) in self.ids[1].iter().zip(out.iter_mut()) {
            *y = self.vars[id.0];
        }
    }
}

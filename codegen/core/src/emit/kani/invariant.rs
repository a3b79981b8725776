//! Invariants: their exact evaluation functions, and one inductive harness per invariant (the
//! invariant obligations of `qloop prove`).

use super::exact::Env;
use super::show::{check, doc_lines, show_cond, spaced};
use super::sigs::Sigs;
use super::Skipped;
use crate::lower::Plan;
use proc_macro2::{Ident, TokenStream};
use quote::{format_ident, quote};

/// The invariants' evaluation functions, read once: an invariant that cannot be evaluated in
/// `i128` disables every harness that assumes it.
pub(super) struct Invariants {
    /// `fn inv_<name>(s: &StateRaw) -> bool` per evaluable invariant.
    pub fns: Vec<TokenStream>,
    /// Their calls on `s`.
    calls: Vec<TokenStream>,
    /// Per invariant, its function's name if it could be evaluated.
    pub ok: Vec<Option<Ident>>,
    /// Why the harnesses that assume every invariant are not emitted (the first invariant
    /// that cannot be evaluated).
    pub blocked: Option<String>,
}

impl Invariants {
    /// Evaluates every invariant of `plan` exactly on raw states.
    pub fn new(plan: &Plan) -> Invariants {
        let mut me = Invariants {
            fns: Vec::new(),
            calls: Vec::new(),
            ok: Vec::new(),
            blocked: None,
        };
        for inv in &plan.prog.invariants {
            let env = Env::states(plan, "s", None);
            let text = show_cond(plan, &[], &inv.cond);
            match env.cond(&inv.cond) {
                Ok(c) => {
                    let f = format_ident!("inv_{}", inv.name);
                    let d = spaced(&format!(
                        "Invariant `{}`: `{text}`, evaluated exactly on raw states.",
                        inv.name
                    ));
                    me.fns.push(quote! {
                        #[doc = #d]
                        fn #f(s: &StateRaw) -> bool { #c }
                    });
                    me.calls.push(quote! { #f(s) });
                    me.ok.push(Some(f));
                }
                Err(why) => {
                    me.blocked.get_or_insert_with(|| {
                        format!(
                            "it assumes invariant `{}` (`{text}`), which cannot be evaluated \
                             exactly in i128 ({why}); `initial` does not check it either",
                            inv.name
                        )
                    });
                    me.ok.push(None);
                }
            }
        }
        me
    }

    /// The body of `fn invariants(s)`: every evaluable invariant.
    pub fn all(&self) -> TokenStream {
        let calls = &self.calls;
        if calls.is_empty() {
            quote! { true }
        } else {
            quote! { #(#calls)&&* }
        }
    }
}

/// One inductive harness per invariant: from any states inside their bounds satisfying every
/// invariant, one step with any input bits keeps it.
pub(super) fn harnesses(
    plan: &Plan,
    sigs: &Sigs,
    invs: &Invariants,
    skipped: &mut Skipped,
) -> Vec<TokenStream> {
    let prog = &plan.prog;
    let (step_args, pre_from_case) = (sigs.step_args(), sigs.pre_from_case());
    let mut out = Vec::new();
    for (inv, f) in prog.invariants.iter().zip(&invs.ok) {
        // Every inductive harness assumes all invariants: if one cannot be evaluated, none
        // is emitted (dropping an assumption could only produce false alarms).
        let (Some(f), None) = (f, &invs.blocked) else {
            skipped.push((
                format!("invariant_{}", inv.name),
                invs.blocked.clone().unwrap_or_default(),
            ));
            continue;
        };
        let text = show_cond(plan, &[], &inv.cond);
        let mut doc = doc_lines(&inv.docs);
        doc.push_str(&format!(
            "Invariant `{}` is inductive: from any states inside their bounds satisfying every \
             invariant, one step with any input bits keeps `{text}`. With `initial`, it holds \
             in every reachable state (the invariant obligations of `qloop prove`).",
            inv.name
        ));
        let harness = format_ident!("invariant_{}", inv.name);
        let literal = format!("invariant `{}` (`{text}`) is false after a step", inv.name);
        let check = check(
            &quote! { holds },
            &literal,
            &format!("{literal}: {{:?}} -> {{:?}}"),
            quote! { pre, post },
        );
        let doc_s = spaced(&doc);
        let cases = super::for_each_case(
            &format_ident!("StepCase"),
            quote! {
                |c: &StepCase| {
                    let pre = #pre_from_case;
                    // Assume: states inside their bounds, invariants hold.
                    if !(in_bounds(&pre) && invariants(&pre)) {
                        return;
                    }
                    let (post, _) = step(#step_args);
                    let holds = #f(&post);
                    #check
                }
            },
        );
        out.push(quote! {
            #[doc = #doc_s]
            #[test]
            #[cfg_attr(kani, kani::proof)]
        #[cfg_attr(kani, kani::solver(kissat))]
            fn #harness() {
                #cases
            }
        });
    }
    out
}

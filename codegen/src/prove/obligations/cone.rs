//! Cone of influence: which values a goal depends on, so that a whole-program query carries
//! lemmas only for those.
//!
//! Only each value's direct dependencies are kept (its operands and, for a load, what the
//! step stored to the signal before it and the tests that chose among the stores); a cone is
//! their closure, walked when a query asks for it. Kept as closures, the cones of a chain of
//! `n` values hold `n²/2` entries: 2·10⁸ for a 20,000-`let` chain.
//!
//! `qloop check`'s loose-bound warning walks the same dependencies, without the tests
//! (`crate::report`).

use crate::ir::SigId;
use crate::lower::lir::{LStmt, Op, ValId};
use crate::lower::Plan;
use std::collections::{BTreeMap, BTreeSet};

/// Cone of influence of every value and post-step signal of a plan.
pub(crate) struct Cone {
    /// Per value (indexed by [`ValId`]): the values it is computed from directly.
    deps: Vec<Vec<ValId>>,
    /// Per state or output: the values its post-step value is stored from, and the tests
    /// of the branches before them.
    post: BTreeMap<SigId, BTreeSet<ValId>>,
}

impl Cone {
    /// The values the post-step values of `sigs` depend on.
    pub fn post_of(&self, sigs: &BTreeSet<SigId>) -> BTreeSet<ValId> {
        self.closure(sigs.iter().flat_map(|&s| self.post_roots(s)))
    }

    /// Value `id` and every value it is computed from, including, through loads, the values
    /// stored before it.
    pub fn val(&self, id: ValId) -> BTreeSet<ValId> {
        self.closure([id])
    }

    /// Whether value `id` depends on no other value (a constant, an input, a load of the
    /// pre-state).
    pub fn alone(&self, id: ValId) -> bool {
        self.deps[id.0].is_empty()
    }

    fn closure(&self, roots: impl IntoIterator<Item = ValId>) -> BTreeSet<ValId> {
        self.closure_until(roots, |_| true)
    }

    /// The values reached from `roots` through the dependencies of the values for which
    /// `expand` holds (the others are reached, not walked through).
    pub fn closure_until(
        &self,
        roots: impl IntoIterator<Item = ValId>,
        expand: impl Fn(ValId) -> bool,
    ) -> BTreeSet<ValId> {
        let mut seen = BTreeSet::new();
        let mut todo: Vec<ValId> = roots.into_iter().collect();
        while let Some(v) = todo.pop() {
            if seen.insert(v) && expand(v) {
                todo.extend(self.deps[v.0].iter().copied());
            }
        }
        seen
    }

    /// The values the post-step value of `sig` is stored from (and the tests before them).
    pub fn post_roots(&self, sig: SigId) -> impl Iterator<Item = ValId> + '_ {
        self.post.get(&sig).into_iter().flatten().copied()
    }

    /// The direct dependencies of every value and post-step signal of `plan`: with `tests`,
    /// a load and a post-step value also depend on the tests of the branches before them.
    pub fn of(plan: &Plan, tests: bool) -> Cone {
        fn walk(
            plan: &Plan,
            stmts: &[LStmt],
            env: &mut BTreeMap<SigId, BTreeSet<ValId>>,
            deps: &mut Vec<Vec<ValId>>,
            tests: bool,
        ) {
            for s in stmts {
                match s {
                    LStmt::Def(id) => {
                        let v = plan.val(*id);
                        let mut d: Vec<ValId> = v.op.operands();
                        if let Op::Load(sig) = v.op {
                            d.extend(env.get(&sig).into_iter().flatten().copied());
                        }
                        deps[id.0] = d;
                    }
                    LStmt::Store(sig, id) => {
                        env.insert(*sig, BTreeSet::from([*id]));
                    }
                    LStmt::If(c, t, e) => {
                        let mut et = env.clone();
                        walk(plan, t, &mut et, deps, tests);
                        let mut ee = env.clone();
                        walk(plan, e, &mut ee, deps, tests);
                        let keys: BTreeSet<SigId> = et.keys().chain(ee.keys()).copied().collect();
                        for k in keys {
                            let mut d: BTreeSet<ValId> = et.get(&k).cloned().unwrap_or_default();
                            d.extend(ee.get(&k).into_iter().flatten().copied());
                            if tests {
                                d.insert(*c);
                            }
                            env.insert(k, d);
                        }
                    }
                }
            }
        }
        let mut deps = vec![Vec::new(); plan.vals.len()];
        let mut post = BTreeMap::new();
        walk(plan, &plan.body, &mut post, &mut deps, tests);
        Cone { deps, post }
    }
}

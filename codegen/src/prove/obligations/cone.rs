//! Cone of influence: which values a goal depends on, so that a whole-program query carries
//! lemmas only for those.

use crate::ir::SigId;
use crate::lower::lir::{LStmt, Op, ValId};
use crate::lower::Plan;
use std::collections::{BTreeMap, BTreeSet};

/// Cone of influence: the values each value, and each post-step signal, depends on.
pub(super) struct Cone {
    /// Per value (indexed by [`ValId`]): itself and every value it is computed from,
    /// including, through loads, the values stored before it.
    pub val: Vec<BTreeSet<ValId>>,
    /// Per state or output: the values its post-step value depends on, branch conditions
    /// included.
    post: BTreeMap<SigId, BTreeSet<ValId>>,
}

impl Cone {
    /// The values the post-step values of `sigs` depend on.
    pub fn post_of(&self, sigs: &BTreeSet<SigId>) -> BTreeSet<ValId> {
        sigs.iter()
            .flat_map(|s| self.post.get(s).into_iter().flatten().copied())
            .collect()
    }

    /// The cone of influence of every value and post-step signal of `plan`.
    pub fn of(plan: &Plan) -> Cone {
        fn walk(
            plan: &Plan,
            stmts: &[LStmt],
            env: &mut BTreeMap<SigId, BTreeSet<ValId>>,
            val: &mut Vec<BTreeSet<ValId>>,
        ) {
            for s in stmts {
                match s {
                    LStmt::Def(id) => {
                        let v = plan.val(*id);
                        let mut d: BTreeSet<ValId> = BTreeSet::from([*id]);
                        for o in v.op.operands() {
                            d.extend(val[o.0].iter().copied());
                        }
                        if let Op::Load(sig) = v.op {
                            d.extend(env.get(&sig).into_iter().flatten().copied());
                        }
                        val[id.0] = d;
                    }
                    LStmt::Store(sig, id) => {
                        env.insert(*sig, val[id.0].clone());
                    }
                    LStmt::If(c, t, e) => {
                        let mut et = env.clone();
                        walk(plan, t, &mut et, val);
                        let mut ee = env.clone();
                        walk(plan, e, &mut ee, val);
                        let keys: BTreeSet<SigId> = et.keys().chain(ee.keys()).copied().collect();
                        for k in keys {
                            let mut d: BTreeSet<ValId> = et.get(&k).cloned().unwrap_or_default();
                            d.extend(ee.get(&k).into_iter().flatten().copied());
                            d.extend(val[c.0].iter().copied());
                            env.insert(k, d);
                        }
                    }
                }
            }
        }
        let mut val = vec![BTreeSet::new(); plan.vals.len()];
        let mut post = BTreeMap::new();
        walk(plan, &plan.body, &mut post, &mut val);
        Cone { val, post }
    }
}

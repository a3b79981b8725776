//! Path conditions: which branches of the plan lead to each value.
//!
//! A value defined inside `if c { .. } else { .. }` exists only on that path, so a lemma about
//! it, or an overflow goal, holds only under the path condition. The condition is kept typed,
//! as the branches taken, until a query is written: [`PathCond::guard`] is the one place that
//! renders it to SMT-LIB.

use crate::lower::lir::{LStmt, ValId};
use crate::lower::Plan;
use crate::prove::smt::vname;
use std::collections::BTreeMap;

/// One branch taken: a branch condition (a boolean plan value) and which way it went.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Branch {
    /// The branch condition.
    pub cond: ValId,
    /// `true` in the then-branch, `false` in the else-branch.
    pub taken: bool,
}

impl Branch {
    /// The SMT-LIB literal: `v3` or `(not v3)`.
    fn smt(self) -> String {
        let c = vname(self.cond);
        if self.taken {
            c
        } else {
            format!("(not {c})")
        }
    }
}

/// The path condition of a value: the conjunction of the branches that enclose its
/// definition, outermost first. No branches means the value is computed on every path.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct PathCond {
    /// The enclosing branches, outermost first.
    branches: Vec<Branch>,
}

impl PathCond {
    /// Every path: the value is not inside any branch.
    pub const ALWAYS: PathCond = PathCond {
        branches: Vec::new(),
    };

    /// This path, one branch deeper.
    pub fn and(&self, branch: Branch) -> PathCond {
        let mut branches = self.branches.clone();
        branches.push(branch);
        PathCond { branches }
    }

    /// The condition as an SMT-LIB term, `None` for [`PathCond::ALWAYS`]. Conjunctions nest
    /// to the left, one branch at a time: `(and (and v3 (not v7)) v9)`.
    pub fn smt(&self) -> Option<String> {
        let mut lits = self.branches.iter().map(|b| b.smt());
        let first = lits.next()?;
        Some(lits.fold(first, |path, lit| format!("(and {path} {lit})")))
    }

    /// `fact` (an SMT-LIB term) as it holds on this path: `(=> path fact)`, or `fact` itself
    /// on every path.
    pub fn guard(&self, fact: String) -> String {
        match self.smt() {
            None => fact,
            Some(path) => format!("(=> {path} {fact})"),
        }
    }
}

/// The path condition of every value of a plan.
#[derive(Clone, Debug, Default)]
pub struct Paths(BTreeMap<ValId, PathCond>);

impl Paths {
    /// Walks the plan's body, recording for each definition the branches around it.
    pub fn of(plan: &Plan) -> Paths {
        fn walk(stmts: &[LStmt], path: &PathCond, out: &mut BTreeMap<ValId, PathCond>) {
            for s in stmts {
                match s {
                    LStmt::Def(id) => {
                        out.insert(*id, path.clone());
                    }
                    LStmt::Store(..) => {}
                    LStmt::If(c, t, e) => {
                        let branch = |taken| Branch { cond: *c, taken };
                        walk(t, &path.and(branch(true)), out);
                        walk(e, &path.and(branch(false)), out);
                    }
                }
            }
        }
        let mut out = BTreeMap::new();
        walk(&plan.body, &PathCond::ALWAYS, &mut out);
        Paths(out)
    }

    /// The path condition of value `id`, if the body defines it.
    pub fn get(&self, id: ValId) -> Option<&PathCond> {
        self.0.get(&id)
    }

    /// `fact` about value `id`, guarded by its path condition (unguarded when the value is
    /// computed on every path, or not defined in the body).
    pub fn guard(&self, id: ValId, fact: String) -> String {
        match self.get(id) {
            Some(path) => path.guard(fact),
            None => fact,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn renders_like_nested_branches() {
        let b = |i, taken| Branch {
            cond: ValId(i),
            taken,
        };
        assert_eq!(PathCond::ALWAYS.smt(), None);
        assert_eq!(PathCond::ALWAYS.guard("f".into()), "f");
        let p = PathCond::ALWAYS.and(b(3, true));
        assert_eq!(p.smt().as_deref(), Some("v3"));
        let p = PathCond::ALWAYS.and(b(3, false));
        assert_eq!(p.smt().as_deref(), Some("(not v3)"));
        let p = p.and(b(7, true)).and(b(9, false));
        assert_eq!(p.smt().as_deref(), Some("(and (and (not v3) v7) (not v9))"));
        assert_eq!(
            p.guard("f".into()),
            "(=> (and (and (not v3) v7) (not v9)) f)"
        );
    }
}

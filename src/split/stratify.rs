//! Stratified evaluation draws (`stratify trajectory keep 1`): the
//! evaluation set is the shuffled universe walked in order, taking a
//! recording only while its condition keeps at least `keep` recordings
//! (deployment units) outside the evaluation set; the validation draw then
//! walks its own shuffle under the same rule for the conditions the
//! evaluation set holds. Every evaluated condition so keeps `keep`
//! recordings for fitting, and the disjoint arm has seen each evaluated
//! condition on other flights. The shuffles are the generator's own, so a
//! design without `stratify` draws exactly what it drew before.

use std::collections::BTreeMap;

use super::SplitError;
use crate::design::Stratify;

/// Each drawable slot's condition (`None` for a name without data, which
/// is drawn freely and never counts as kept), and the totals.
pub(super) struct Strata<'a> {
    spec: &'a Stratify,
    condition: Vec<Option<String>>,
    total: BTreeMap<String, usize>,
}

impl<'a> Strata<'a> {
    pub(super) fn new(spec: &'a Stratify, condition: Vec<Option<String>>) -> Strata<'a> {
        let mut total = BTreeMap::new();
        for c in condition.iter().flatten() {
            *total.entry(c.clone()).or_insert(0) += 1;
        }
        Strata { spec, condition, total }
    }

    /// The conditions' names as the clause declares them.
    fn what(&self) -> String {
        let names: Vec<&str> = self.spec.conditions.iter().map(|c| c.name()).collect();
        format!("`stratify {} keep {}`", names.join(", "), self.spec.keep)
    }

    /// Walks `order` (slots) and takes up to `n`: a slot whose condition,
    /// with `taken` already drawn from it, keeps `keep` outside; `held`
    /// counts what earlier sets took (the evaluation set, for validation)
    /// and `constrained` says which conditions the rule applies to.
    fn walk(
        &self,
        order: &[usize],
        n: usize,
        held: &BTreeMap<String, usize>,
        constrained: &dyn Fn(&str) -> bool,
    ) -> (Vec<usize>, BTreeMap<String, usize>) {
        let mut taken: BTreeMap<String, usize> = BTreeMap::new();
        let mut out = Vec::with_capacity(n);
        for &slot in order {
            if out.len() == n {
                break;
            }
            match &self.condition[slot] {
                None => out.push(slot),
                Some(c) => {
                    let used = held.get(c).copied().unwrap_or(0) + taken.get(c).copied().unwrap_or(0);
                    if !constrained(c) || self.total[c] - used > self.spec.keep {
                        *taken.entry(c.clone()).or_insert(0) += 1;
                        out.push(slot);
                    }
                }
            }
        }
        (out, taken)
    }

    /// The stratified evaluation set: the first `n` slots of `order` that
    /// keep `keep` of their condition outside; refused, at the clause, when
    /// fewer can be taken.
    pub(super) fn evaluation(&self, order: &[usize], n: usize) -> Result<Vec<usize>, SplitError> {
        let (out, _) = self.walk(order, n, &BTreeMap::new(), &|_| true);
        if out.len() < n {
            let short: Vec<String> =
                self.total.iter().filter(|(_, &t)| t <= self.spec.keep).map(|(c, t)| format!("{c} ({t})")).collect();
            let short = if short.is_empty() {
                String::new()
            } else {
                format!(
                    "; conditions with no more than {} recording(s), never drawn: {}",
                    self.spec.keep,
                    short.join(", ")
                )
            };
            return Err(SplitError::Stratify {
                detail: format!(
                    "{} cannot draw {n} evaluation recordings: only {} of the {} recordings can be drawn while each drawn condition keeps {} other recording(s) for fitting{short}; lower `evaluation`, lower `keep`, or stratify by fewer conditions",
                    self.what(),
                    out.len(),
                    self.condition.len(),
                    self.spec.keep
                ),
                offset: self.spec.offset,
            });
        }
        Ok(out)
    }

    /// The validation set drawn from `order` (slots outside `evaluation`)
    /// so that every evaluated condition still keeps `keep` for fitting.
    pub(super) fn validation(&self, order: &[usize], n: usize, evaluation: &[usize]) -> Result<Vec<usize>, SplitError> {
        let mut held: BTreeMap<String, usize> = BTreeMap::new();
        for c in evaluation.iter().filter_map(|&s| self.condition[s].as_ref()) {
            *held.entry(c.clone()).or_insert(0) += 1;
        }
        let (out, _) = self.walk(order, n, &held, &|c| held.contains_key(c));
        if out.len() < n {
            return Err(SplitError::Stratify {
                detail: format!(
                    "{} leaves only {} recordings for {n} validation recordings once each evaluated condition keeps {} for fitting; lower the validation recordings or `keep`",
                    self.what(),
                    out.len(),
                    self.spec.keep
                ),
                offset: self.spec.offset,
            });
        }
        Ok(out)
    }
}

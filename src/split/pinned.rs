//! Names a design pins: evaluation and validation recordings listed by
//! name, and a published split's fit roles.

use super::*;

/// The slots of the pinned `listed` names: a name matches a slot by its own
/// name or, under `duplicates group`, by any member of its unit. Two names
/// of one unit are refused.
pub(super) fn pinned(
    listed: &[ListedName],
    slots: &[(String, Slot)],
    members: &dyn Fn(usize) -> Vec<String>,
    what: &'static str,
    metadata: bool,
) -> Result<Vec<usize>, SplitError> {
    let found: Vec<usize> = listed
        .iter()
        .map(|l| {
            let hit = slots
                .iter()
                .position(|(n, slot)| *n == l.name || matches!(slot, Slot::Unit(u) if members(*u).contains(&l.name)));
            hit.ok_or_else(|| match &l.at {
                Some((path, line, column)) => SplitError::Located {
                    path: path.clone(),
                    line: *line,
                    column: *column,
                    message: format!(
                        "{what} recording \"{}\" is not among the {} recordings the split draws from{}",
                        l.name,
                        slots.len(),
                        if metadata {
                            " (it has neither an included CSV nor a metadata file)"
                        } else {
                            " (it has no included CSV)"
                        }
                    ),
                },
                None => SplitError::NotInUniverse {
                    what,
                    name: l.name.clone(),
                    offset: l.offset,
                    available: slots.len(),
                    hint: if metadata {
                        " (it has neither an included CSV nor a metadata file)".to_string()
                    } else {
                        " (it has no included CSV; `universe metadata` also admits names listed only by metadata)"
                            .to_string()
                    },
                },
            })
        })
        .collect::<Result<_, _>>()?;
    for (i, c) in found.iter().enumerate() {
        if let Some(j) = found[..i].iter().position(|d| d == c) {
            return Err(SplitError::SameUnit { first: listed[j].name.clone(), second: listed[i].name.clone() });
        }
    }
    Ok(found)
}

/// Splits chosen slots into loaded unit indices and absent names; absent
/// names are an error unless the design allows them.
pub(super) fn resolve(
    chosen: &[usize],
    slots: &[(String, Slot)],
    what: &'static str,
    allowed: bool,
) -> Result<(Vec<usize>, Vec<String>), SplitError> {
    let mut units = Vec::new();
    let mut absent = Vec::new();
    for &c in chosen {
        match &slots[c].1 {
            Slot::Unit(u) => units.push(*u),
            Slot::Absent(name) => absent.push(name.clone()),
        }
    }
    absent.sort();
    if !absent.is_empty() && !allowed {
        return Err(SplitError::Absent { what, names: absent.join(", ") });
    }
    Ok((units, absent))
}

/// Fit recordings, absent names, and (copy, held-out original) pairs dropped.
pub(super) type PublishedFit = (Vec<usize>, Vec<String>, Vec<(String, String)>);

/// The fit recordings of a published split: its fit roles' names, without
/// the ones the design excludes by name (`exclude recordings`: listed as
/// absent), without the ones that have no usable data (an error unless
/// `missing csv allow`)
/// and, under `leaked drop`, without copies of a held-out recording (an
/// error under `leaked refuse`). Returns the recordings, the absent names
/// and the dropped (copy, held-out original) pairs.
pub(super) fn published_fit(
    pin: &PublishedPin,
    (slots, units, info): (&[(String, Slot)], &[DeploymentUnit], &[RecordingInfo]),
    held: &[usize],
    (allowed, excluded): (bool, &[&str]),
) -> Result<PublishedFit, SplitError> {
    let mut recordings = BTreeSet::new();
    let mut absent = Vec::new();
    let mut leaked = Vec::new();
    // Fit files the design excludes by name: absent as it says, and named
    // with the other absent fit recordings, without `missing csv allow`.
    let mut left_out = Vec::new();
    for l in &pin.fit {
        if excluded.contains(&l.name.as_str()) {
            left_out.push(l.name.clone());
            continue;
        }
        let unit = slots.iter().find_map(|(_, slot)| match slot {
            Slot::Unit(u) if units[*u].members.iter().any(|&m| info[m].name == l.name) => Some(*u),
            _ => None,
        });
        let Some(u) = unit else {
            if slots.iter().any(|(n, _)| *n == l.name) {
                absent.push(l.name.clone());
                continue;
            }
            let (path, line, column) = l.at.clone().unwrap_or_default();
            return Err(SplitError::Located {
                path,
                line,
                column,
                message: format!(
                    "fit recording \"{}\" has neither a CSV nor a metadata file in the data directory",
                    l.name
                ),
            });
        };
        // The listed recording itself (under `duplicates group` its unit may hold copies listed elsewhere).
        let Some(&r) = units[u].members.iter().find(|&&m| info[m].name == l.name) else { continue };
        match held.iter().find(|&&h| h == r || info[h].content_hash == info[r].content_hash) {
            Some(&h) => leaked.push((info[r].name.clone(), info[h].name.clone())),
            None => {
                recordings.insert(r);
            }
        }
    }
    absent.sort();
    if !absent.is_empty() && !allowed {
        return Err(SplitError::Absent { what: "fit", names: absent.join(", ") });
    }
    absent.extend(left_out);
    absent.sort();
    if !leaked.is_empty() && pin.leaked == LeakPolicy::Refuse {
        let list =
            leaked.iter().map(|(c, h)| format!("  {c} (fit) is identical to {h}")).collect::<Vec<_>>().join("\n");
        return Err(SplitError::PublishedLeak { file: pin.file.clone(), count: leaked.len(), list });
    }
    Ok((recordings.into_iter().collect(), absent, leaked))
}

//! `split published "FILE" { evaluation ROLE; validation ROLE; fit ROLE }`:
//! the split file is read here, every role of it must be mapped (or
//! ignored), and its names become the design's pinned recordings, each
//! remembering where the split file lists it.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::Validator;
use crate::design::ast::*;
use crate::design::*;

/// A resolved `split published`: the pin and the evaluation and validation
/// names it gives the recording factor and the validation statement.
pub(super) struct Pinned {
    pub pin: PublishedPin,
    pub evaluation: Vec<ListedName>,
    pub validation: Vec<ListedName>,
}

type Roles = Option<Vec<Spanned<String>>>;

/// The items of a `split published` block: the roles mapped to each part
/// of the design, those ignored, and the policy on leaked recordings.
struct RoleItems {
    evaluation: Roles,
    validation: Roles,
    fit: Roles,
    ignore: Vec<Spanned<String>>,
    leaked: LeakPolicy,
}

impl Validator {
    pub(super) fn published(
        &mut self,
        file: &Spanned<String>,
        folders: bool,
        data: Option<&DataSpec>,
        items: &[Spanned<PublishedItem>],
        span: Span,
    ) -> Option<Pinned> {
        let RoleItems { evaluation, validation, fit, ignore, leaked } = self.role_items(items, span);
        let (split, path) = self.read_published(file, folders, data)?;
        let groups: [(&'static str, &[Spanned<String>]); 4] = [
            ("evaluation", evaluation.as_deref().unwrap_or(&[])),
            ("validation", validation.as_deref().unwrap_or(&[])),
            ("fit", fit.as_deref().unwrap_or(&[])),
            ("ignore", &ignore),
        ];
        let mapped = self.map_roles(&split, &path, groups, file.span);
        let shown = path.display().to_string();
        let names = |what: &str| -> Vec<ListedName> {
            split
                .roles
                .iter()
                .filter(|r| mapped.iter().any(|(n, w)| *n == r.name && *w == what))
                .flat_map(|r| r.entries.iter())
                .map(|e| ListedName {
                    name: e.name.clone(),
                    offset: file.span.start,
                    at: Some((shown.clone(), e.at.line, e.at.column)),
                })
                .collect()
        };
        let pinned_evaluation = names("evaluation");
        if evaluation.is_some() && pinned_evaluation.len() < 2 {
            self.err(
                "too few recordings",
                span,
                format!(
                    "the evaluation roles list {} recording(s); a crossed design needs at least 2",
                    pinned_evaluation.len()
                ),
            );
        }
        let roles_of =
            |what: &str| -> Vec<String> { mapped.iter().filter(|(_, w)| *w == what).map(|(n, _)| n.clone()).collect() };
        let pin = PublishedPin {
            // The lock records the listing's hash under this name.
            file: match (folders, data.and_then(|d| d.path.as_deref())) {
                (true, Some(dir)) => format!("folders of {dir}"),
                _ => file.node.clone(),
            },
            sha256: split.sha256.clone(),
            format: split.format,
            evaluation_roles: roles_of("evaluation"),
            validation_roles: roles_of("validation"),
            fit_roles: roles_of("fit"),
            ignored_roles: roles_of("ignore"),
            leaked,
            fit: names("fit"),
        };
        Some(Pinned { pin, evaluation: pinned_evaluation, validation: names("validation") })
    }

    /// The block's items, each mapping given once; the evaluation and fit
    /// roles are required.
    fn role_items(&mut self, items: &[Spanned<PublishedItem>], span: Span) -> RoleItems {
        let mut seen = BTreeMap::new();
        let mut roles =
            RoleItems { evaluation: None, validation: None, fit: None, ignore: Vec::new(), leaked: LeakPolicy::Refuse };
        for item in items {
            match &item.node {
                PublishedItem::Evaluation(r) => {
                    self.once(&mut seen, "evaluation", item.span);
                    roles.evaluation = Some(r.clone());
                }
                PublishedItem::Validation(r) => {
                    self.once(&mut seen, "validation", item.span);
                    roles.validation = Some(r.clone());
                }
                PublishedItem::Fit(r) => {
                    self.once(&mut seen, "fit", item.span);
                    roles.fit = Some(r.clone());
                }
                PublishedItem::Ignore(r) => roles.ignore.extend(r.iter().cloned()),
                PublishedItem::Leaked(p) => {
                    self.once(&mut seen, "leaked", item.span);
                    roles.leaked = if p.node == "drop" { LeakPolicy::Drop } else { LeakPolicy::Refuse };
                }
            }
        }
        // A split of train and test alone maps no validation role: the
        // design's `validation` statement draws from the fit roles.
        let missing: Vec<&str> = [("evaluation", &roles.evaluation), ("fit", &roles.fit)]
            .iter()
            .filter(|(_, r)| r.is_none())
            .map(|(n, _)| *n)
            .collect();
        if !missing.is_empty() {
            self.err_help(
                "incomplete published split",
                span,
                format!("missing: {}", missing.join(", ")),
                "map the split file's roles: `evaluation test; fit train` (and `validation val` where it has one)",
            );
        }
        roles
    }

    /// The split file (or, with `folders`, the data folder's subfolders)
    /// read as whole recordings, with the path it was read from; `None`
    /// with an error when it cannot be.
    fn read_published(
        &mut self,
        file: &Spanned<String>,
        folders: bool,
        data: Option<&DataSpec>,
    ) -> Option<(crate::published::PublishedSplit, PathBuf)> {
        let resolve = |p: &str| if Path::new(p).is_absolute() { PathBuf::from(p) } else { self.base.join(p) };
        let read = if folders {
            let nested = data.and_then(|d| d.format.as_ref()).is_some_and(|f| f.nested_folders);
            match data.and_then(|d| d.path.as_deref()) {
                Some(dir) if nested => {
                    // A log beside the role folders is in no role: it would
                    // be audited and never used, without a word.
                    let loose: Vec<String> = crate::io::walk::files_below(&resolve(dir), false)
                        .unwrap_or_default()
                        .iter()
                        .filter_map(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
                        .filter(|n| crate::io::walk::is_log_name(n))
                        .collect();
                    if !loose.is_empty() {
                        self.err_help(
                            "logs in no role folder",
                            file.span,
                            format!(
                                "{} log(s) lie in the data folder itself, in no role folder of the split ({}): the split would never use them",
                                loose.len(),
                                crate::io::excerpt(&loose.join(", "), 300)
                            ),
                            "move each into a role folder (train/, test/, ...), or out of the data folder",
                        );
                        return None;
                    }
                    crate::published::from_folders(&resolve(dir))
                }
                _ => {
                    self.err_help(
                        "no folders to split by",
                        file.span,
                        "`split published folders` takes the roles from the data folder's subfolders",
                        "declare `data csv { path \"...\" folders nested ... }`",
                    );
                    return None;
                }
            }
        } else {
            crate::published::read(&resolve(&file.node))
        };
        let path = match (folders, data.and_then(|d| d.path.as_deref())) {
            (true, Some(dir)) => resolve(dir),
            _ => resolve(&file.node),
        };
        match read.and_then(crate::published::PublishedSplit::whole_recordings) {
            Ok(s) => Some((s, path)),
            Err(e) => {
                let help = match e {
                    crate::published::PublishedError::Folders { .. } => {
                        "the role of each log is the first folder it lies in under the data folder"
                    }
                    _ => "a relative path is read from the design file's folder",
                };
                self.err_help("cannot use the published split", file.span, e.to_string(), help);
                None
            }
        }
    }

    /// Each role named in the block (`groups`: the roles mapped to each
    /// part) checked against the split's roles, as (role, part): a role the
    /// split lacks, one mapped twice and one the block leaves unmapped are
    /// refused.
    fn map_roles(
        &mut self,
        split: &crate::published::PublishedSplit,
        path: &Path,
        groups: [(&'static str, &[Spanned<String>]); 4],
        file: Span,
    ) -> Vec<(String, &'static str)> {
        let known = split.roles.iter().map(|r| format!("`{}`", r.name)).collect::<Vec<_>>().join(", ");
        let mut mapped: Vec<(String, &'static str)> = Vec::new();
        for (what, roles) in groups {
            for r in roles {
                if split.role(&r.node).is_none() {
                    self.err_help(
                        "unknown role",
                        r.span,
                        format!("{} has no role `{}`", path.display(), r.node),
                        format!("its roles are {known}"),
                    );
                } else if let Some((_, first)) = mapped.iter().find(|(n, _)| *n == r.node) {
                    self.err("role mapped twice", r.span, format!("role `{}` is already mapped to {first}", r.node));
                } else {
                    mapped.push((r.node.clone(), what));
                }
            }
        }
        for role in &split.roles {
            if !mapped.iter().any(|(n, _)| *n == role.name) {
                self.err_help(
                    "unmapped role",
                    file,
                    format!(
                        "role `{}` of {} ({} recordings) is not mapped",
                        role.name,
                        path.display(),
                        role.entries.len()
                    ),
                    format!(
                        "map it with `evaluation`, `validation` or `fit`, or leave it out with `ignore {}`",
                        role.name
                    ),
                );
            }
        }
        mapped
    }

    /// The published split whose validation roles give the validation
    /// recordings, if any. A split of train and test alone has none: its
    /// validation recordings are drawn from its fit roles (or listed), as
    /// without a published split, and `from split` is refused.
    pub(super) fn validation_roles<'p>(
        &mut self,
        published: Option<&'p Pinned>,
        recordings: &ValRecordings,
    ) -> Option<&'p Pinned> {
        let roles = published.filter(|p| !p.pin.validation_roles.is_empty());
        if let (Some(p), None, ValRecordings::Split(span)) = (published, roles, recordings) {
            self.err_help(
                "no validation role",
                *span,
                format!("the published split maps no role to validation (its fit roles are {})", p.pin.fit_roles.join(", ")),
                "draw validation recordings from the fit roles, `validation N windows from K recordings seed S`, or map a role: `validation val`",
            );
        }
        roles
    }
}

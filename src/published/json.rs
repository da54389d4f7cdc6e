//! Split files in JSON: NanoBench's `split_metadata.json` (role name ->
//! list of recordings) and fold lists, read by a small parser that keeps
//! every value's line and column and refuses duplicate keys.

use std::collections::BTreeMap;

use super::types::*;

/// A JSON value with the place of each node (the text has already been
/// accepted by serde_json, so this reader can be simple).
#[derive(Debug)]
enum Node {
    Str(String),
    Arr(Vec<(Place, Node)>),
    Obj(Vec<(Place, String, Place, Node)>),
    /// Numbers, booleans and null, as written.
    Scalar(String),
}

/// The form, roles and scalar notes of a split file.
type Read = (Format, Vec<DeclaredRole>, BTreeMap<String, String>);

pub(super) fn from_json(path: &str, text: &str) -> Result<Read, PublishedError> {
    if let Err(e) = serde_json::from_str::<serde_json::Value>(text) {
        return Err(at(
            path,
            Place { line: e.line().max(1), column: e.column().max(1) },
            format!("malformed JSON: {e}"),
        ));
    }
    let mut p = Parser { text, i: 0, line: 1, column: 1 };
    p.ws();
    let (top_at, top) = p.value();
    no_duplicate_keys(path, &top)?;
    match top {
        Node::Arr(folds) => Ok((Format::FoldJson, fold_roles(path, folds)?, BTreeMap::new())),
        Node::Obj(members) if members.iter().any(|(_, k, _, _)| k == "folds") => fold_object(path, members),
        Node::Obj(members) => {
            let mut roles = Vec::new();
            let mut notes = BTreeMap::new();
            for (kat, key, vat, v) in members {
                match (key.strip_suffix("_files"), v) {
                    (Some(role), Node::Arr(items)) if !role.is_empty() => {
                        let entries = names(path, items, &format!("`{key}`"))?;
                        roles.push(DeclaredRole { name: role.to_string(), at: kat, entries });
                    }
                    (Some(""), _) => {
                        return Err(at(
                            path,
                            kat,
                            "the key `_files` names no role: a NanoBench split names its roles `<role>_files` (train_files, val_files, test_files)",
                        ))
                    }
                    (Some(_), _) => return Err(at(path, vat, format!("`{key}` must be a list of file paths"))),
                    (None, Node::Scalar(s)) => {
                        notes.insert(key, s);
                    }
                    (None, Node::Str(s)) => {
                        notes.insert(key, s);
                    }
                    (None, _) => {
                        return Err(at(
                            path,
                            kat,
                            format!("unknown key `{key}`: a NanoBench split names its roles `<role>_files` (train_files, val_files, test_files)"),
                        ))
                    }
                }
            }
            Ok((Format::NanobenchJson, roles, notes))
        }
        _ => Err(at(path, top_at, "a split file is an object of `<role>_files` lists (NanoBench), or a list of folds")),
    }
}

/// An object with a `folds` list: besides it, only scalar notes (`seed`).
/// A `<role>_files` list beside `folds` would be a second, conflicting
/// split; any other list or object is unknown. Neither is dropped quietly.
fn fold_object(path: &str, members: Vec<(Place, String, Place, Node)>) -> Result<Read, PublishedError> {
    let mut folds = None;
    let mut notes = BTreeMap::new();
    for (kat, key, vat, v) in members {
        match (key.as_str(), v) {
            ("folds", Node::Arr(list)) => folds = Some(list),
            ("folds", _) => return Err(at(path, vat, "`folds` must be a list of lists of recording names")),
            (k, _) if k.ends_with("_files") => {
                return Err(at(
                    path,
                    kat,
                    format!("`{key}` beside `folds`: a split file is either a fold list or NanoBench `<role>_files` lists, not both"),
                ))
            }
            (_, Node::Scalar(s) | Node::Str(s)) => {
                notes.insert(key, s);
            }
            (_, _) => {
                return Err(at(
                    path,
                    kat,
                    format!("unknown key `{key}` beside `folds`: a fold list's object holds `folds` and scalar notes (`seed`) only"),
                ))
            }
        }
    }
    let folds = folds.expect("called with a `folds` key");
    Ok((Format::FoldJson, fold_roles(path, folds)?, notes))
}

/// A key written twice in one object: JSON readers keep one of the two
/// silently (serde_json the last), so a second `folds` or `test_files`
/// would be dropped or win without a word.
fn no_duplicate_keys(path: &str, node: &Node) -> Result<(), PublishedError> {
    match node {
        Node::Arr(items) => items.iter().try_for_each(|(_, n)| no_duplicate_keys(path, n)),
        Node::Obj(members) => {
            let mut seen: BTreeMap<&str, Place> = BTreeMap::new();
            for (kat, key, _, v) in members {
                if let Some(first) = seen.insert(key, *kat) {
                    return Err(at(
                        path,
                        *kat,
                        format!(
                            "key `{key}` appears twice in one object (first at line {}, column {}); JSON readers would keep only one of them",
                            first.line, first.column
                        ),
                    ));
                }
                no_duplicate_keys(path, v)?;
            }
            Ok(())
        }
        Node::Str(_) | Node::Scalar(_) => Ok(()),
    }
}

fn fold_roles(path: &str, folds: Vec<(Place, Node)>) -> Result<Vec<DeclaredRole>, PublishedError> {
    folds
        .into_iter()
        .enumerate()
        .map(|(k, (place, fold))| match fold {
            Node::Arr(items) => Ok(DeclaredRole {
                name: format!("fold{k}"),
                at: place,
                entries: names(path, items, &format!("fold {k}"))?,
            }),
            _ => Err(at(path, place, format!("fold {k} must be a list of recording names"))),
        })
        .collect()
}

fn names(path: &str, items: Vec<(Place, Node)>, what: &str) -> Result<Vec<Entry>, PublishedError> {
    items
        .into_iter()
        .map(|(place, item)| match item {
            Node::Str(listed) => Ok(Entry { name: stem(&listed), listed, at: place, window: None }),
            _ => Err(at(path, place, format!("{what}: every entry must be a recording name or path (a string)"))),
        })
        .collect()
}

struct Parser<'a> {
    text: &'a str,
    i: usize,
    line: usize,
    column: usize,
}

impl Parser<'_> {
    fn peek(&self) -> Option<char> {
        self.text[self.i..].chars().next()
    }

    fn bump(&mut self) -> Option<char> {
        let c = self.peek()?;
        self.i += c.len_utf8();
        if c == '\n' {
            self.line += 1;
            self.column = 1;
        } else {
            self.column += 1;
        }
        Some(c)
    }

    fn ws(&mut self) {
        while self.peek().is_some_and(|c| c.is_whitespace()) {
            self.bump();
        }
    }

    fn place(&self) -> Place {
        Place { line: self.line, column: self.column }
    }

    /// A value at the cursor (whitespace skipped before it); valid JSON only.
    fn value(&mut self) -> (Place, Node) {
        let place = self.place();
        let node = match self.peek() {
            Some('"') => Node::Str(self.string()),
            Some('[') => Node::Arr(self.items(']', Parser::value)),
            Some('{') => Node::Obj(self.items('}', |p| {
                let kat = p.place();
                let key = p.string();
                p.ws();
                p.bump(); // ':'
                p.ws();
                let (vat, v) = p.value();
                (kat, key, vat, v)
            })),
            _ => {
                let start = self.i;
                while self.peek().is_some_and(|c| !(c == ',' || c == ']' || c == '}' || c.is_whitespace())) {
                    self.bump();
                }
                Node::Scalar(self.text[start..self.i].to_string())
            }
        };
        (place, node)
    }

    /// The comma-separated items of the list or object opening at the
    /// cursor, up to its `close` character.
    fn items<T>(&mut self, close: char, mut item: impl FnMut(&mut Self) -> T) -> Vec<T> {
        self.bump();
        let mut out = Vec::new();
        loop {
            self.ws();
            if self.peek() == Some(close) {
                self.bump();
                return out;
            }
            out.push(item(self));
            self.ws();
            if self.peek() == Some(',') {
                self.bump();
            }
        }
    }

    /// A string literal at the cursor, decoded by serde_json.
    fn string(&mut self) -> String {
        let start = self.i;
        self.bump();
        while let Some(c) = self.bump() {
            match c {
                '\\' => {
                    self.bump();
                }
                '"' => break,
                _ => {}
            }
        }
        serde_json::from_str(&self.text[start..self.i]).unwrap_or_default()
    }
}

//! `conditions name "PATTERN"`: a recording's trajectory, speed and
//! repetition read from its file name.

/// A file-name pattern: literal text and the placeholders `{trajectory}`,
/// `{speed}`, `{rep}` (digits) and `{*}`, each matching a non-empty part.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NamePattern {
    pieces: Vec<NamePiece>,
}

#[derive(Debug, Clone, PartialEq, Eq)]
enum NamePiece {
    Literal(String),
    Trajectory,
    Speed,
    Rep,
    Any,
}

/// What a file name's pattern gives.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct NameConditions {
    /// `{trajectory}`'s part.
    pub trajectory: Option<String>,
    /// `{speed}`'s part.
    pub speed: Option<String>,
    /// `{rep}`'s digits.
    pub repetition: Option<u32>,
}

impl NamePattern {
    /// Parses a pattern; the error says what is wrong with it.
    pub fn parse(text: &str) -> Result<NamePattern, String> {
        let mut pieces = Vec::new();
        let mut rest = text;
        while !rest.is_empty() {
            match rest.find('{') {
                Some(0) => {
                    let close = rest.find('}').ok_or_else(|| format!("`{rest}`: a `{{` without its `}}`"))?;
                    let piece = match &rest[1..close] {
                        "trajectory" => NamePiece::Trajectory,
                        "speed" => NamePiece::Speed,
                        "rep" => NamePiece::Rep,
                        "*" => NamePiece::Any,
                        other => {
                            return Err(format!(
                                "`{{{other}}}` is not a placeholder (known: {{trajectory}}, {{speed}}, {{rep}}, {{*}})"
                            ))
                        }
                    };
                    if pieces.last().is_some_and(|p| !matches!(p, NamePiece::Literal(_))) {
                        return Err(format!(
                            "two placeholders in a row before `{}`: put literal text between them, or the split is ambiguous",
                            &rest[..=close]
                        ));
                    }
                    if pieces.contains(&piece) && piece != NamePiece::Any {
                        return Err(format!("`{}` appears twice", &rest[..=close]));
                    }
                    pieces.push(piece);
                    rest = &rest[close + 1..];
                }
                found => {
                    let end = found.unwrap_or(rest.len());
                    if rest[..end].contains('}') {
                        return Err(format!("`{}`: a `}}` without its `{{`", &rest[..end]));
                    }
                    pieces.push(NamePiece::Literal(rest[..end].to_string()));
                    rest = &rest[end..];
                }
            }
        }
        if !pieces.iter().any(|p| matches!(p, NamePiece::Trajectory | NamePiece::Speed)) {
            return Err("the pattern needs `{trajectory}` or `{speed}`".to_string());
        }
        Ok(NamePattern { pieces })
    }

    /// The conditions of `name` (a file name without `.csv[.gz]`), or
    /// `None` when the pattern does not match it.
    pub fn conditions(&self, name: &str) -> Option<NameConditions> {
        let mut out = NameConditions::default();
        self.match_from(0, name, &mut out).then_some(out)
    }

    /// Matches `pieces[k..]` against `rest`, trying every split (names are short).
    fn match_from(&self, k: usize, rest: &str, out: &mut NameConditions) -> bool {
        let Some(piece) = self.pieces.get(k) else { return rest.is_empty() };
        if let NamePiece::Literal(l) = piece {
            return rest.strip_prefix(l.as_str()).is_some_and(|r| self.match_from(k + 1, r, out));
        }
        for end in rest.char_indices().map(|(i, c)| i + c.len_utf8()) {
            let part = &rest[..end];
            if *piece == NamePiece::Rep && !part.bytes().all(|b| b.is_ascii_digit()) {
                break;
            }
            let mut tried = out.clone();
            match piece {
                NamePiece::Trajectory => tried.trajectory = Some(part.to_string()),
                NamePiece::Speed => tried.speed = Some(part.to_string()),
                NamePiece::Rep => tried.repetition = part.parse().ok(),
                _ => {}
            }
            if self.match_from(k + 1, &rest[end..], &mut tried) {
                *out = tried;
                return true;
            }
        }
        false
    }
}

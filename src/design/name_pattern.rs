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

    /// Whether the pattern gives a recording's trajectory (or speed).
    pub fn gives(&self, condition: super::Condition) -> bool {
        let want = match condition {
            super::Condition::Trajectory => NamePiece::Trajectory,
            super::Condition::Speed => NamePiece::Speed,
        };
        self.pieces.contains(&want)
    }

    /// The conditions of `name` (a file name without `.csv[.gz]`), or
    /// `None` when the pattern does not match it. Each placeholder takes
    /// the shortest part that lets the rest of the pattern match (the
    /// first split in reading order). Linear in the name's length for each
    /// piece: which suffixes each tail of the pattern matches is tabled
    /// once, so no split is tried twice (a search over splits is
    /// exponential in the number of `{*}`).
    pub fn conditions(&self, name: &str) -> Option<NameConditions> {
        // Character boundaries: index b is byte offset at[b].
        let at: Vec<usize> = (0..=name.len()).filter(|&i| name.is_char_boundary(i)).collect();
        let index = |byte: usize| at.binary_search(&byte).ok();
        let m = at.len() - 1;
        let p = self.pieces.len();
        // digits[b]: the last boundary c >= b with name[at[b]..at[c]] all ASCII digits.
        let mut digits = vec![0usize; m + 1];
        for b in (0..=m).rev() {
            digits[b] = if b < m && name.as_bytes()[at[b]].is_ascii_digit() { digits[b + 1] } else { b };
        }
        // ok[k][b]: pieces[k..] match name[at[b]..].
        let mut ok = vec![vec![false; m + 1]; p + 1];
        ok[p][m] = true;
        for k in (0..p).rev() {
            // next[b]: the smallest c > b with ok[k + 1][c] (m + 1: none).
            let mut next = vec![m + 1; m + 2];
            for b in (0..m).rev() {
                next[b] = if ok[k + 1][b + 1] { b + 1 } else { next[b + 1] };
            }
            for b in 0..=m {
                ok[k][b] = match &self.pieces[k] {
                    NamePiece::Literal(l) => name[at[b]..]
                        .starts_with(l.as_str())
                        .then(|| index(at[b] + l.len()))
                        .flatten()
                        .is_some_and(|c| ok[k + 1][c]),
                    NamePiece::Rep => b < m && next[b] <= digits[b],
                    _ => b < m && next[b] <= m,
                };
            }
        }
        if !ok[0][0] {
            return None;
        }
        // The first split in reading order: each placeholder's shortest part.
        let mut out = NameConditions::default();
        let mut b = 0;
        for (k, piece) in self.pieces.iter().enumerate() {
            let c = match piece {
                NamePiece::Literal(l) => index(at[b] + l.len())?,
                _ => (b + 1..=m).find(|&c| ok[k + 1][c])?,
            };
            let part = &name[at[b]..at[c]];
            match piece {
                NamePiece::Trajectory => out.trajectory = Some(part.to_string()),
                NamePiece::Speed => out.speed = Some(part.to_string()),
                NamePiece::Rep => out.repetition = part.parse().ok(),
                _ => {}
            }
            b = c;
        }
        Some(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The definition the table implements: every split tried in reading
    /// order, shortest part first (exponential; fine for short names).
    fn by_search(p: &NamePattern, k: usize, rest: &str, out: &mut NameConditions) -> bool {
        let Some(piece) = p.pieces.get(k) else { return rest.is_empty() };
        if let NamePiece::Literal(l) = piece {
            return rest.strip_prefix(l.as_str()).is_some_and(|r| by_search(p, k + 1, r, out));
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
            if by_search(p, k + 1, &rest[end..], &mut tried) {
                *out = tried;
                return true;
            }
        }
        false
    }

    #[test]
    fn the_table_gives_the_first_split_in_reading_order() -> Result<(), Box<dyn std::error::Error>> {
        let patterns = [
            "{trajectory}_{speed}_rep{rep}",
            "{*}_{trajectory}-{speed}_take{rep}",
            "{trajectory}_{*}_{speed}",
            "{*}a{trajectory}a{*}",
            "{speed}a{*}",
            "x{rep}a{trajectory}",
        ];
        // Every name over a small alphabet up to length 7, and some UTF-8.
        let alphabet = ['a', '_', '-', '1', '2', 'é'];
        let mut names = vec![String::new()];
        let mut all = Vec::new();
        for _ in 0..6 {
            let mut longer = Vec::new();
            for n in &names {
                for c in alphabet {
                    longer.push(format!("{n}{c}"));
                }
            }
            all.extend(longer.iter().cloned());
            names = longer;
        }
        all.extend(["R3_circle_fast_rep2", "2026-05-02_lissajous-medium_take12", "x12circle"].map(String::from));
        for text in patterns {
            let p = NamePattern::parse(text)?;
            for name in &all {
                let mut want = NameConditions::default();
                let want = by_search(&p, 0, name, &mut want).then_some(want);
                assert_eq!(p.conditions(name), want, "{text} on {name:?}");
            }
        }
        Ok(())
    }

    #[test]
    fn many_wildcards_on_a_long_name_that_does_not_match() -> Result<(), Box<dyn std::error::Error>> {
        // Four `{*}a` pieces against 200 `a`s and no `_x` end: a search over
        // splits tries about 200^4 of them.
        let p = NamePattern::parse("{trajectory}_{*}a{*}a{*}a{*}a_x")?;
        let name = format!("t_{}b", "a".repeat(200));
        assert_eq!(p.conditions(&name), None);
        let hit = format!("t_{}_x", "a".repeat(200));
        assert_eq!(p.conditions(&hit).and_then(|c| c.trajectory).as_deref(), Some("t"));
        Ok(())
    }
}

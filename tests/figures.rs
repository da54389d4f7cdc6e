//! Every committed figure reads: no axis of any SVG under `results/` or
//! `docs/` has two neighbouring tick labels that are equal (a label
//! precision coarser than the step plotters draws, as the lab study's
//! interaction axis once read `-0.03, -0.03, -0.02, -0.02`).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::common::root;

fn svgs(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            svgs(&p, out);
        } else if p.extension().is_some_and(|x| x == "svg") {
            out.push(p);
        }
    }
}

/// The numeric tick labels of one SVG, per axis in document order: a
/// vertical axis's labels share their x and end there (`text-anchor="end"`),
/// a horizontal axis's share their y. Rotated text (axis titles) is left out.
fn axes(svg: &str) -> BTreeMap<(bool, String), Vec<String>> {
    let flat = svg.replace('\n', " ");
    let attr = |tag: &str, name: &str| {
        let key = format!(" {name}=\"");
        tag.find(&key).map(|i| tag[i + key.len()..].split('"').next().unwrap_or("").to_string())
    };
    let mut out: BTreeMap<(bool, String), Vec<String>> = BTreeMap::new();
    for piece in flat.split("<text").skip(1) {
        let Some((tag, rest)) = piece.split_once('>') else { continue };
        let label = rest.split("</text>").next().unwrap_or("").trim().to_string();
        let number = label.trim_end_matches('%');
        if tag.contains("rotate") || number.parse::<f64>().is_err() {
            continue;
        }
        let vertical = attr(tag, "text-anchor").as_deref() == Some("end");
        let at = if vertical { attr(tag, "x") } else { attr(tag, "y") };
        out.entry((vertical, at.unwrap_or_default())).or_default().push(label);
    }
    out
}

#[test]
fn no_committed_figure_repeats_a_tick_label_on_an_axis() {
    let mut files = Vec::new();
    svgs(&root().join("results"), &mut files);
    svgs(&root().join("docs"), &mut files);
    assert!(files.len() > 20, "only {} SVGs found", files.len());
    let mut bad = Vec::new();
    for f in &files {
        let svg = std::fs::read_to_string(f).unwrap();
        for ((vertical, at), labels) in axes(&svg) {
            if let Some(w) = labels.windows(2).find(|w| w[0] == w[1]) {
                let axis = if vertical { "vertical axis at x" } else { "horizontal axis at y" };
                bad.push(format!("{} ({axis} {at}): {:?} in {labels:?}", f.display(), w[0]));
            }
        }
    }
    assert!(bad.is_empty(), "neighbouring tick labels repeat:\n{}", bad.join("\n"));
}

/// The reader sees the repetition it is there to catch.
#[test]
fn the_figure_check_catches_a_repeated_label() {
    let svg = r#"<svg><text x="90" y="408" text-anchor="end">-0.03</text>
<text x="90" y="390" text-anchor="end">-0.03</text><text x="90" y="371" text-anchor="end">-0.02</text>
<text x="154" y="420" text-anchor="middle">0.5</text></svg>"#;
    let a = axes(svg);
    assert_eq!(a[&(true, "90".to_string())], ["-0.03", "-0.03", "-0.02"]);
    assert_eq!(a[&(false, "420".to_string())], ["0.5"]);
}

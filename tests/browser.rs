//! The quickstart's and the paper multiverse's report.html in a real
//! browser: Debian's chromium, headless, opens the committed pages (which
//! `tests/run_integrity.rs` and the multiverse tests reproduce byte for byte).
//! Nothing may fail to load or raise an error, every figure must render
//! with a real size and everything drawn inside its own box (no tick label
//! or title cut at an edge), the banner must carry the decision, and the
//! quickstart's screenshot must match the
//! committed one (`tests/fixtures/browser/quickstart_report.png`) within a
//! tolerance. Without chromium the test passes after a SKIPPED line, unless
//! CROSSAUDIT_REQUIRE_BROWSER is set (`.ci/run` installs chromium and sets
//! it). To accept a changed page: `CROSSAUDIT_BLESS_SCREENSHOT=1 cargo test
//! browser` rewrites the reference, which is then reviewed and committed.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::common::root;

fn chromium() -> Option<PathBuf> {
    ["/usr/bin/chromium", "/usr/bin/chromium-browser", "/usr/bin/google-chrome"]
        .iter()
        .map(PathBuf::from)
        .find(|p| p.is_file())
}

/// Headless chromium with no network, no profile and a fixed window.
fn browser(bin: &Path, profile: &Path) -> Command {
    let mut c = Command::new(bin);
    c.args([
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--hide-scrollbars",
        "--force-device-scale-factor=1",
        "--window-size=1200,1600",
    ]);
    c.arg(format!("--user-data-dir={}", profile.display()));
    c
}

const PROBE_HEAD: &str = "<script>window.__errors=[];window.addEventListener('error',function(e){window.__errors.push(String(e.message||(e.target&&(e.target.src||e.target.href))||'error'))},true);</script>";
/// Measures, after load: each figure's name, its rendered size, its
/// rendered box and the horizontal extent of everything drawn in it (the
/// union of its elements' boxes, text included, the background left out), the figure element's box,
/// the banner's text and any load errors.
const PROBE_TAIL: &str = "<script>window.addEventListener('load',function(){var f=[].slice.call(document.querySelectorAll('figure svg')).map(function(s){var r=s.getBoundingClientRect(),b=s.parentElement.getBoundingClientRect(),l=Infinity,h=-Infinity;[].slice.call(s.querySelectorAll('*')).forEach(function(e){var q=e.getBoundingClientRect();if((q.width>0||q.height>0)&&!(e.tagName=='rect'&&q.width>=r.width-1)){l=Math.min(l,q.left);h=Math.max(h,q.right)}});return {name:s.parentElement.getAttribute('data-figure'),width:Math.round(r.width),height:Math.round(r.height),left:r.left,right:r.right,drawn_left:l,drawn_right:h,box_left:b.left,box_right:b.right}});var b=document.querySelector('.banner');var p=document.createElement('pre');p.id='measured';p.textContent=JSON.stringify({figures:f,banner:b?b.textContent:null,errors:window.__errors});document.body.appendChild(p)});</script>";

fn unescape(s: &str) -> String {
    s.replace("&lt;", "<").replace("&gt;", ">").replace("&quot;", "\"").replace("&amp;", "&")
}

fn decode(path: &Path) -> (u32, u32, Vec<u8>) {
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(path).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    let channels = info.color_type.samples();
    // RGB only, whatever the PNG's layout.
    let rgb: Vec<u8> =
        buf[..info.buffer_size()].chunks(channels).flat_map(|p| [p[0], p[1 % channels], p[2 % channels]]).collect();
    (info.width, info.height, rgb)
}

/// Headless chromium, or None after a SKIPPED line (a failure where
/// CROSSAUDIT_REQUIRE_BROWSER is set).
fn chromium_or_skip() -> Option<PathBuf> {
    let bin = chromium();
    if bin.is_none() {
        assert!(
            std::env::var_os("CROSSAUDIT_REQUIRE_BROWSER").is_none(),
            "chromium is not installed and CROSSAUDIT_REQUIRE_BROWSER is set"
        );
        crate::common::skip("chromium", "browser test: needs Debian's chromium (apt-get install chromium)");
    }
    bin
}

/// Opens `report` (a copy with the probes added) in chromium and checks
/// what every page must do: load without an error, carry the decision in
/// its banner, draw inline every figure its report.md names, each at a
/// real size, with everything drawn inside the figure's own box (no tick
/// label or title cut at an edge) and the figure inside the page's column.
fn check_page(bin: &Path, report: &Path, banner_has: &[&str]) {
    let html = std::fs::read_to_string(report).unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let probed = html.replacen("<head>", &format!("<head>\n{PROBE_HEAD}"), 1).replacen(
        "</body>",
        &format!("{PROBE_TAIL}\n</body>"),
        1,
    );
    let page = tmp.path().join("page.html");
    std::fs::write(&page, probed).unwrap();
    let out = browser(bin, &tmp.path().join("profile"))
        .args(["--virtual-time-budget=5000", "--dump-dom"])
        .arg(format!("file://{}", page.display()))
        .output()
        .unwrap();
    let dom = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "chromium failed: {}", String::from_utf8_lossy(&out.stderr));
    let start = dom.find("<pre id=\"measured\">").unwrap_or_else(|| panic!("the probe did not run:\n{dom}")) + 19;
    let end = start + dom[start..].find("</pre>").unwrap();
    let m: serde_json::Value = serde_json::from_str(&unescape(&dom[start..end])).unwrap();
    assert_eq!(m["errors"], serde_json::json!([]), "errors while loading {}", report.display());
    let banner = m["banner"].as_str().unwrap();
    for want in banner_has {
        assert!(banner.contains(want), "{}: banner lacks {want:?}: {banner}", report.display());
    }
    let figures = m["figures"].as_array().unwrap();
    let names: Vec<&str> = figures.iter().map(|f| f["name"].as_str().unwrap()).collect();
    let md = std::fs::read_to_string(report.with_file_name("report.md")).unwrap();
    let expected: Vec<&str> = md
        .lines()
        .filter_map(|l| l.strip_prefix("!["))
        .filter_map(|l| l.split_once("]("))
        .map(|(_, f)| f.trim_end_matches(')'))
        .collect();
    assert!(!expected.is_empty(), "{} names no figure", report.display());
    assert_eq!(names, expected, "every figure report.md names is drawn inline");
    let x = |f: &serde_json::Value, k: &str| f[k].as_f64().unwrap_or_else(|| panic!("{k} of {f}"));
    for f in figures {
        let (w, h) = (x(f, "width"), x(f, "height"));
        assert!(w > 100.0 && h > 100.0, "figure {} renders at {w} x {h}", f["name"]);
        assert!(
            x(f, "drawn_left") >= x(f, "left") - 1.0 && x(f, "drawn_right") <= x(f, "right") + 1.0,
            "{}: {} is drawn over {:.0}..{:.0} px but its box is {:.0}..{:.0} px (something is cut)",
            report.display(),
            f["name"],
            x(f, "drawn_left"),
            x(f, "drawn_right"),
            x(f, "left"),
            x(f, "right")
        );
        assert!(
            x(f, "left") >= x(f, "box_left") - 1.0 && x(f, "right") <= x(f, "box_right") + 1.0,
            "{}: {} is wider than its figure element",
            report.display(),
            f["name"]
        );
    }
}

#[test]
fn the_quickstart_report_renders_in_a_real_browser() {
    let Some(bin) = chromium_or_skip() else { return };
    let report = root().join("results/quickstart/report/report.html");
    check_page(&bin, &report, &["decision: ", "Preregistered"]);
    let tmp = tempfile::tempdir().unwrap();

    // The page as a person sees it, against the committed screenshot.
    let shot = tmp.path().join("shot.png");
    let out = browser(&bin, &tmp.path().join("profile2"))
        .arg(format!("--screenshot={}", shot.display()))
        .arg(format!("file://{}", report.display()))
        .output()
        .unwrap();
    assert!(out.status.success() && shot.is_file(), "no screenshot: {}", String::from_utf8_lossy(&out.stderr));
    let reference = root().join("tests/fixtures/browser/quickstart_report.png");
    if std::env::var_os("CROSSAUDIT_BLESS_SCREENSHOT").is_some() {
        std::fs::create_dir_all(reference.parent().unwrap()).unwrap();
        std::fs::copy(&shot, &reference).unwrap();
        return;
    }
    let (w, h, a) = decode(&shot);
    let (rw, rh, b) = decode(&reference);
    assert_eq!((w, h), (rw, rh), "screenshot size");
    let differing =
        a.chunks(3).zip(b.chunks(3)).filter(|(p, q)| p.iter().zip(q.iter()).any(|(x, y)| x.abs_diff(*y) > 64)).count();
    let share = differing as f64 / (w * h) as f64;
    if share > 0.02 {
        let keep = std::env::temp_dir().join("crossaudit_quickstart_report.png");
        let _ = std::fs::copy(&shot, &keep);
        panic!(
            "{:.1}% of the screenshot's pixels differ from the reference (fresh one kept at {})",
            100.0 * share,
            keep.display()
        );
    }
}

/// The paper multiverse's page (written by `analyze` of the committed run):
/// the specification curve drawn whole, nothing cut, no load error.
#[test]
fn the_multiverse_report_renders_in_a_real_browser() {
    let Some(bin) = chromium_or_skip() else { return };
    check_page(&bin, &root().join("results/multiverse/paper/report/report.html"), &["CONFIRMED", "Preregistered"]);
}

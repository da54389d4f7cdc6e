//! The `numpy_legacy` split generator against numpy itself: every vector in
//! tests/data/numpy_legacy_vectors.json was written by
//! scripts/reference/numpy_legacy_vectors.py (numpy's legacy RandomState).

use crossaudit::split::RandomState;
use serde_json::Value;

fn checksum(a: &[usize]) -> u64 {
    let m: u128 = (1 << 61) - 1;
    (a.iter().enumerate().map(|(i, &v)| (i as u128 + 1) * v as u128).sum::<u128>() % m) as u64
}

fn ints(v: &Value) -> Vec<usize> {
    v.as_array().unwrap().iter().map(|x| x.as_u64().unwrap() as usize).collect()
}

#[test]
fn numpy_legacy_matches_numpy_bit_for_bit() {
    let text = std::fs::read_to_string("tests/data/numpy_legacy_vectors.json").unwrap();
    let doc: Value = serde_json::from_str(&text).unwrap();
    let cases = doc["cases"].as_array().unwrap();
    let mut kinds = std::collections::BTreeMap::new();
    for case in cases {
        let kind = case["kind"].as_str().unwrap();
        let seed = u32::try_from(case["seed"].as_u64().unwrap()).unwrap();
        let args = ints(&case["args"]);
        let mut rs = RandomState::new(seed);
        let got: Vec<usize> = match kind {
            "permutation" => rs.permutation(args[0]),
            "choice" => rs.choice(args[0], args[1]),
            "shuffle" => {
                let mut a: Vec<usize> = (100..100 + args[0]).collect();
                rs.shuffle(&mut a);
                a
            }
            "sequence" => {
                let mut out = rs.permutation(args[0]);
                out.truncate(args[1]);
                for &n in &args[2..5] {
                    out.extend(rs.choice(n, args[5]));
                }
                out
            }
            other => panic!("unknown case kind {other}"),
        };
        let head = ints(&case["head"]);
        assert_eq!(got.len() as u64, case["len"].as_u64().unwrap(), "{kind} seed {seed} {args:?}: length");
        assert_eq!(&got[..head.len()], &head[..], "{kind} seed {seed} {args:?}: first values");
        assert_eq!(checksum(&got), case["checksum"].as_u64().unwrap(), "{kind} seed {seed} {args:?}: checksum");
        *kinds.entry(kind.to_string()).or_insert(0) += 1;
    }
    // The vectors cover every call the split makes, and the paper's two seeds.
    assert!(kinds["permutation"] >= 60 && kinds["choice"] >= 7 && kinds["shuffle"] >= 3, "{kinds:?}");
    let has = |kind: &str, seed: u64, n: u64| {
        cases.iter().any(|c| c["kind"] == kind && c["seed"] == seed && c["args"][0] == n)
    };
    assert!(has("permutation", 42, 106) && has("choice", 42, 106) && has("choice", 143, 80));
}

/// numpy: `np.random.RandomState(42).permutation(106)[:26]`, printed by hand
/// from numpy 2.4.6; the paper's evaluation draw.
#[test]
fn seed_42_over_106_is_the_papers_draw() {
    let e = RandomState::new(42).choice(106, 26);
    assert_eq!(&e[..6], &[100, 10, 4, 81, 97, 65]);
}

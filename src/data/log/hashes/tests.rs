use super::super::{parse, parse_with, ParseOptions, Schema};
use super::hashes;

fn named(columns: &[&str]) -> Schema {
    Schema::Named { columns: columns.iter().map(|c| c.to_string()).collect(), time: Some("t".into()) }
}

#[test]
fn the_definition_written_out_as_bytes() {
    // The content hash is XXH3-128 of: columns and rows as u64
    // little-endian, then each row's values' bits; a row's hash XXH3-64 of
    // its values' bits. Written out here by hand and hashed in one call.
    let columns = vec![vec![0.0, 0.01], vec![1.5, f64::NAN], vec![-2.0, 3.25]];
    let mut bytes = Vec::new();
    bytes.extend_from_slice(&3u64.to_le_bytes());
    bytes.extend_from_slice(&2u64.to_le_bytes());
    let rows = [[0.0f64, 1.5, -2.0], [0.01, f64::NAN, 3.25]];
    let mut each = Vec::new();
    for row in rows {
        let mut b = Vec::new();
        for v in row {
            b.extend_from_slice(&v.to_bits().to_le_bytes());
        }
        each.push(xxhash_rust::xxh3::xxh3_64(&b));
        bytes.extend_from_slice(&b);
    }
    let (content, row_hashes) = hashes(&columns, 2, true);
    assert_eq!(content, format!("{:032x}", xxhash_rust::xxh3::xxh3_128(&bytes)));
    assert_eq!(row_hashes, each);
    assert!(hashes(&columns, 2, false).1.is_empty());
}

#[test]
fn the_same_values_hash_the_same_whatever_wrote_their_text() {
    let schema = named(&["t", "x"]);
    let a = parse("a.csv", b"t,x,note\n0.000000000,0.015879000,first\n0.01,1e0,a\n", &schema).unwrap();
    let b = parse("b.csv", b"x,t,note\n0.015879,0,second\r\n1.0,0.010,b\r\n", &schema).unwrap();
    assert_eq!(a.content_hash, b.content_hash);
    let rows = |text: &[u8]| super::super::parse_with_row_hashes("c.csv", text, &schema).unwrap().row_hashes;
    assert_eq!(rows(b"t,x\n0,0.5\n1,2\n"), rows(b"t,x,y\n0.0,5e-1,9\n1.00,2.0,9\n"));
}

#[test]
fn another_value_read_changes_the_hashes() {
    let schema = named(&["t", "x"]);
    let base = super::super::parse_with_row_hashes("a.csv", b"t,x\n0,1\n1,2\n", &schema).unwrap();
    // One value; a sign of zero (atan2 tells -0.0 from 0.0); one row more.
    for other in [&b"t,x\n0,1\n1,2.000001\n"[..], b"t,x\n0,1\n1,2\n2,3\n", b"t,x\n0,-0.0\n1,2\n", b"t,x\n0,0.0\n1,2\n"]
    {
        let log = super::super::parse_with_row_hashes("b.csv", other, &schema).unwrap();
        assert_ne!(log.content_hash, base.content_hash, "{}", String::from_utf8_lossy(other));
    }
    let zero = super::super::parse_with_row_hashes("z.csv", b"t,x\n0,0.0\n1,2\n", &schema).unwrap();
    let negative = super::super::parse_with_row_hashes("n.csv", b"t,x\n0,-0.0\n1,2\n", &schema).unwrap();
    assert_ne!(zero.row_hashes[0], negative.row_hashes[0]);
    assert_eq!(zero.row_hashes[1], negative.row_hashes[1]);
    // The same file read in another order is another table; the same
    // numbers in the same roles, whatever the columns' order in the file,
    // are the same one.
    let other_order = parse("a.csv", b"t,x\n0,1\n1,2\n", &named(&["x", "t"])).unwrap();
    assert_ne!(other_order.content_hash, base.content_hash);
    let swapped = parse("s.csv", b"x,t\n1,0\n2,1\n", &schema).unwrap();
    assert_eq!(swapped.content_hash, base.content_hash);
}

#[test]
fn a_missing_value_hashes_as_nan_whatever_its_text() {
    let schema = named(&["t", "x"]);
    let options = ParseOptions { missing_as_nan: true, ..ParseOptions::default() };
    let logs: Vec<_> = [&b"t,x\n0,\n1,2\n"[..], b"t,x\n0,NaN\n1,2\n", b"t,x\n0,-nan\n1,2\n", b"t,x\n0,inf\n1,2\n"]
        .iter()
        .map(|text| parse_with("m.csv", text, &schema, options).unwrap())
        .collect();
    for log in &logs[1..] {
        assert_eq!(log.content_hash, logs[0].content_hash);
    }
    // A table of one shape is not its transpose's.
    assert_ne!(hashes(&[vec![1.0, 2.0]], 2, false).0, hashes(&[vec![1.0], vec![2.0]], 1, false).0);
}

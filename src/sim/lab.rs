//! A lab's folder as a lab publishes it, simulated: the fixture behind
//! `crossaudit simulate-lab` and `designs/logs/lab.design`.
//!
//! Twenty-one flights (seven trajectories, three takes each) flown by the
//! simulator of [`super::fly`], written the way a real lab's logs look:
//! Parquet files in `train/` and `test/` folders (take 2 of each
//! trajectory in `test/`), the lab's own column names, a timestamp in
//! nanoseconds, an onboard quaternion 1.2 to 1.8% longer than unit length
//! (an estimator that does not renormalise what it logs), motion-capture
//! quaternion columns that are all NaN, float32 gyro columns and a text
//! column nobody declares. Two flights are broken as real ones are: in
//! `lab-star-take3` the motion capture loses the vehicle at 60% of the
//! flight and repeats its last position while the motors keep working; in
//! `lab-oval-take1` the logger stalls for 5 s (a gap in the timestamps).

use std::path::Path;
use std::sync::Arc;

use parquet::basic::{Compression, LogicalType, Repetition, TimeUnit, Type as Physical};
use parquet::column::writer::ColumnWriter;
use parquet::data_type::ByteArray;
use parquet::file::properties::WriterProperties;
use parquet::file::writer::SerializedFileWriter;
use parquet::schema::types::Type;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use super::SimulateError;

/// The trajectories flown, each at 0.6 m/s.
pub const LAB_TRAJECTORIES: [&str; 7] = ["circle", "figure_eight", "helix", "oval", "star", "trefoil", "lissajous"];

/// The flight whose motion capture freezes.
pub const CRASHED: &str = "lab-star-take3";

/// The flight with a 5 s gap in its timestamps.
pub const GAPPED: &str = "lab-oval-take1";

/// One column of a lab log.
enum Column {
    Double(Vec<f64>),
    Float(Vec<f32>),
    Text(Vec<String>),
    Nanos(Vec<i64>),
}

/// Writes the 21 flights into `dir/train` and `dir/test`; deterministic
/// for `seed` (flight k uses ChaCha8 stream k). Returns the files written,
/// relative to `dir`.
pub fn simulate_lab(dir: &Path, seed: u64) -> Result<Vec<String>, SimulateError> {
    let err = |source| SimulateError::Write { dir: dir.display().to_string(), source };
    let flights: Vec<(usize, &str, usize)> = LAB_TRAJECTORIES
        .iter()
        .enumerate()
        .flat_map(|(i, t)| (1..=3).map(move |take| (i * 3 + take - 1, *t, take)))
        .collect();
    for folder in ["train", "test"] {
        std::fs::create_dir_all(dir.join(folder)).map_err(err)?;
    }
    flights
        .into_par_iter()
        .map(|(k, trajectory, take)| {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            rng.set_stream(k as u64);
            let t0 = 1_780_000_000.0 + 1000.0 * k as f64;
            let (text, _, _, _) = super::flight::fly(trajectory, 0.6, 20.0, 1.0, &mut rng, t0);
            let name = format!("lab-{trajectory}-take{take}");
            let folder = if take == 2 { "test" } else { "train" };
            let columns = lab_columns(&text, &name, &mut rng);
            let rel = format!("{folder}/{name}.parquet");
            let path = dir.join(&rel);
            let tmp = crate::io::staged(&path).map_err(err)?;
            write_parquet(&tmp, &columns).map_err(|e| err(std::io::Error::other(e)))?;
            std::fs::rename(&tmp, &path).map_err(err)?;
            Ok(rel)
        })
        .collect()
}

/// The simulator's NanoBench text as the lab's columns, broken as `name`
/// is.
fn lab_columns(text: &str, name: &str, rng: &mut ChaCha8Rng) -> Vec<(&'static str, Column)> {
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap_or_default().split(',').collect();
    let rows: Vec<Vec<f64>> = lines
        .filter(|l| !l.is_empty())
        .map(|l| l.split(',').map(|f| f.parse().unwrap_or(f64::NAN)).collect())
        .collect();
    let mut rows = rows;
    if name == GAPPED {
        // The logger stalls for 5 s at 40% of the flight.
        let at = rows.len() * 2 / 5;
        rows.drain(at..(at + 500).min(rows.len()));
    }
    let col = |n: &str| -> Vec<f64> {
        let c = header.iter().position(|h| *h == n).unwrap_or(0);
        rows.iter().map(|r| r[c]).collect()
    };
    let (mut x, mut y, mut z) = (col("px"), col("py"), col("pz"));
    if name == CRASHED {
        // Motion capture loses the vehicle: its last reading repeats.
        let at = rows.len() * 3 / 5;
        for v in [&mut x, &mut y, &mut z] {
            let held = v[at];
            v[at..].iter_mut().for_each(|p| *p = held);
        }
    }
    // The onboard quaternion 1.2 to 1.8% long, wobbling a little.
    let long = 1.012 + 0.004 * rng.gen::<f64>();
    let scale: Vec<f64> = (0..rows.len()).map(|k| long + 0.001 * (k as f64 * 0.01).sin()).collect();
    let q = |n: &str| -> Vec<f64> { col(n).iter().zip(&scale).map(|(v, s)| v * s).collect() };
    let n = rows.len();
    let gyro = |rng: &mut ChaCha8Rng| -> Vec<f32> { (0..n).map(|_| rng.gen_range(-0.05f32..0.05)).collect() };
    let active = col("motor_motor_m1");
    vec![
        ("timestamp", Column::Nanos(col("t").iter().map(|t| (t * 1e9).round() as i64).collect())),
        ("pos_x", Column::Double(x)),
        ("pos_y", Column::Double(y)),
        ("pos_z", Column::Double(z)),
        ("vel_x", Column::Double(col("est_stateEstimate_vx"))),
        ("vel_y", Column::Double(col("est_stateEstimate_vy"))),
        ("vel_z", Column::Double(col("est_stateEstimate_vz"))),
        ("quat_w", Column::Double(q("att_stateEstimate_qw"))),
        ("quat_x", Column::Double(q("att_stateEstimate_qx"))),
        ("quat_y", Column::Double(q("att_stateEstimate_qy"))),
        ("quat_z", Column::Double(q("att_stateEstimate_qz"))),
        ("mocap_qw", Column::Double(vec![f64::NAN; n])),
        ("mocap_qx", Column::Double(vec![f64::NAN; n])),
        ("mocap_qy", Column::Double(vec![f64::NAN; n])),
        ("mocap_qz", Column::Double(vec![f64::NAN; n])),
        ("ref_x", Column::Double(col("sp_ctrltarget_x"))),
        ("ref_y", Column::Double(col("sp_ctrltarget_y"))),
        ("ref_z", Column::Double(col("sp_ctrltarget_z"))),
        ("vbat", Column::Double(col("pwr_pm_vbat"))),
        ("cmd_m1", Column::Double(active.clone())),
        ("cmd_m2", Column::Double(col("motor_motor_m2"))),
        ("cmd_m3", Column::Double(col("motor_motor_m3"))),
        ("cmd_m4", Column::Double(col("motor_motor_m4"))),
        ("gyro_x", Column::Float(gyro(rng))),
        ("gyro_y", Column::Float(gyro(rng))),
        ("gyro_z", Column::Float(gyro(rng))),
        ("mode", Column::Text(active.iter().map(|m| if *m > 1000.0 { "flight" } else { "ground" }.into()).collect())),
    ]
}

/// Writes `columns` as one snappy-compressed row group.
fn write_parquet(path: &Path, columns: &[(&str, Column)]) -> Result<(), parquet::errors::ParquetError> {
    let fields = columns
        .iter()
        .map(|(name, c)| {
            let (physical, logical) = match c {
                Column::Double(_) => (Physical::DOUBLE, None),
                Column::Float(_) => (Physical::FLOAT, None),
                Column::Text(_) => (Physical::BYTE_ARRAY, Some(LogicalType::String)),
                Column::Nanos(_) => (Physical::INT64, Some(LogicalType::timestamp(true, TimeUnit::NANOS))),
            };
            Type::primitive_type_builder(name, physical)
                .with_logical_type(logical)
                .with_repetition(Repetition::REQUIRED)
                .build()
                .map(Arc::new)
        })
        .collect::<Result<Vec<_>, _>>()?;
    let schema = Arc::new(Type::group_type_builder("lab_log").with_fields(fields).build()?);
    let props = Arc::new(WriterProperties::builder().set_compression(Compression::SNAPPY).build());
    let file = std::fs::File::create(path)?;
    let mut writer = SerializedFileWriter::new(file, schema, props)?;
    let mut group = writer.next_row_group()?;
    let mut k = 0;
    while let Some(mut col) = group.next_column()? {
        match (col.untyped(), &columns[k].1) {
            (ColumnWriter::DoubleColumnWriter(w), Column::Double(v)) => w.write_batch(v, None, None)?,
            (ColumnWriter::FloatColumnWriter(w), Column::Float(v)) => w.write_batch(v, None, None)?,
            (ColumnWriter::Int64ColumnWriter(w), Column::Nanos(v)) => w.write_batch(v, None, None)?,
            (ColumnWriter::ByteArrayColumnWriter(w), Column::Text(v)) => {
                let v: Vec<ByteArray> = v.iter().map(|s| ByteArray::from(s.as_str())).collect();
                w.write_batch(&v, None, None)?
            }
            _ => return Err(parquet::errors::ParquetError::General(format!("column {k}: type and writer disagree"))),
        };
        col.close()?;
        k += 1;
    }
    group.close()?;
    writer.close()?;
    Ok(())
}

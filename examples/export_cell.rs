//! Exports one training cell's data for the PyTorch reference
//! (benches/reference/): the arm's fit windows and the shared validation
//! windows as raw state, raw action and standardized target, the input
//! standardizer, the registered starts' rollout inputs, and the training
//! settings. Little-endian f32 files plus cell.json.
//!
//!     cargo run --release --example export_cell -- DESIGN MODEL ARM SEED OUT_DIR

use std::io::Write;
use std::path::{Path, PathBuf};

use crossaudit::design::{InputMap, ModelKind};
use crossaudit::model::features::{raw_input, raw_target};
use crossaudit::model::FeatureMap;

fn write_f32(path: &Path, values: impl Iterator<Item = f64>) -> std::io::Result<usize> {
    let mut f = std::io::BufWriter::new(std::fs::File::create(path)?);
    let mut n = 0;
    for v in values {
        f.write_all(&(v as f32).to_le_bytes())?;
        n += 1;
    }
    f.flush()?;
    Ok(n)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let a: Vec<String> = std::env::args().collect();
    if a.len() != 6 {
        return Err("usage: export_cell DESIGN MODEL ARM SEED OUT_DIR".into());
    }
    let file = crossaudit::design::load(Path::new(&a[1]))?;
    let (model, arm, seed, out) = (&a[2], &a[3], a[4].parse::<u64>()?, PathBuf::from(&a[5]));
    std::fs::create_dir_all(&out)?;
    let dir = crossaudit::run::data_dir(&file.design, &file.path, None, &out)?.dir;
    let split_dir = out.join("split");
    let o = crossaudit::split::prepare(&file, &crossaudit::compile(&file.design), &dir, &split_dir)?;
    let m = file.design.models.iter().find(|m| m.name == *model).ok_or("no such model")?;
    let ModelKind::Mlp { widths, inputs, actions, .. } = &m.kind else { return Err("not an MLP".into()) };
    let triples = |ws: &[crossaudit::split::Window]| -> Vec<_> {
        ws.iter()
            .map(|w| {
                let r = &o.recordings[w.recording];
                (r.state[w.t].clone(), r.action[w.t].clone(), r.state[w.t + 1].clone())
            })
            .collect::<Vec<_>>()
    };
    let fit = triples(o.split.fit(arm).ok_or("no such arm")?);
    let val = triples(&o.split.validation);
    let target = file.design.training.as_ref().ok_or("no train block")?.target;
    let slots = file.design.data.slots();
    let fm = FeatureMap::fit(slots, *inputs, *actions, target, &fit, "export");
    for (name, set) in [("fit", &fit), ("val", &val)] {
        // Raw network input before standardization (the map's raw input with
        // the clean action), raw action, standardized target.
        write_f32(
            &out.join(format!("{name}_raw_input.f32")),
            set.iter().flat_map(|(x, u, _)| raw_input(&slots, *inputs, x, u)),
        )?;
        let mut z = vec![0f32; slots.state];
        let targets: Vec<f64> = set
            .iter()
            .flat_map(|(x, _, n)| {
                fm.target.apply(&raw_target(&slots, x, n), &mut z);
                z.iter().map(|v| f64::from(*v)).collect::<Vec<_>>()
            })
            .collect();
        write_f32(&out.join(format!("{name}_target.f32")), targets.into_iter())?;
    }
    let t = file.design.training.clone().ok_or("no train block")?;
    let meta = serde_json::json!({
        "design": a[1], "model": model, "arm": arm, "seed": seed, "widths": widths,
        "inputs": if *inputs == InputMap::World { "world" } else { "relative" },
        "n_fit": fit.len(), "n_val": val.len(), "input_mean": fm.input.mean, "input_std": fm.input.std,
        "lr": t.lr, "batch": t.batch, "epochs": t.epochs, "patience": t.patience, "action_noise": t.action_noise,
        "cosine": matches!(t.schedule, crossaudit::design::Schedule::Cosine),
        "rollout_starts": o.split.starts.len(), "rollout_steps": o.split.horizon,
    });
    std::fs::write(out.join("cell.json"), serde_json::to_string_pretty(&meta)?)?;
    eprintln!("exported {} fit and {} validation windows to {}", fit.len(), val.len(), out.display());
    Ok(())
}

//! Every log of an audit loaded (in parallel) and given its row: judged
//! by the rules, or excluded as unreadable, with its metadata's state and
//! the recording the caller keeps.

use std::path::{Path, PathBuf};

use rayon::prelude::*;

use super::judge::{judged, meta_path, unreadable};
use super::policies;
use super::row::{FileRow, Keep};
use super::AuditError;
use crate::data::metadata::{read_metadata, Metadata};
use crate::data::{load_recording, Layout, Recording};
use crate::design::{DataSource, DataSpec, TailPolicy};

/// Every log loaded (in parallel) and given its row, with the recording
/// `keep` asks for; a declared `refuse` stops the audit at the first file,
/// in name order.
pub(super) fn load_files(
    spec: &DataSpec,
    dir: &Path,
    csvs: &[PathBuf],
    layout: &Layout,
    keep: Keep,
) -> Result<(Vec<FileRow>, Vec<Option<Recording>>), AuditError> {
    let loaded: Vec<(FileRow, Option<Recording>, Option<AuditError>)> =
        csvs.par_iter().map(|path| load_file(spec, dir, path, layout, keep)).collect();
    let mut files = Vec::with_capacity(loaded.len());
    let mut recordings = Vec::with_capacity(loaded.len());
    for (file, recording, refused) in loaded {
        if let Some(e) = refused {
            return Err(e);
        }
        files.push(file);
        recordings.push(recording);
    }
    Ok((files, recordings))
}

/// One log's row, its recording if `keep` asks for it, and the error a
/// declared `refuse` policy makes of a log that cannot be loaded.
fn load_file(
    spec: &DataSpec,
    dir: &Path,
    path: &Path,
    layout: &Layout,
    keep: Keep,
) -> (FileRow, Option<Recording>, Option<AuditError>) {
    let exists = meta_path(path).exists();
    // `data csv` logs need no metadata file; NanoBench's each have one.
    let meta = if !exists && spec.source == DataSource::Csv {
        Ok(Metadata::default())
    } else {
        read_metadata(&meta_path(path))
    };
    let broken = meta.as_ref().err().filter(|_| exists).cloned();
    let mut refused = None;
    let (mut row, rec) = match load_recording(path, layout) {
        Ok(mut rec) => {
            if spec.tails == TailPolicy::Truncate {
                rec.truncate_tail();
            }
            let mut row = judged(spec, &rec, meta);
            row.file = crate::io::walk::relative(dir, path);
            let kept = match keep {
                Keep::None => None,
                Keep::Included => Some(rec),
                Keep::RowHashes => Some(Recording { row_hashes: rec.row_hashes, ..Recording::empty() }),
            };
            (row, kept)
        }
        Err(e) => {
            refused = policies::refusal(spec, &e);
            let mut row = unreadable(spec, path, meta, e.to_string());
            row.file = crate::io::walk::relative(dir, path);
            (row, None)
        }
    };
    row.broken_metadata = broken;
    (row, rec, refused)
}

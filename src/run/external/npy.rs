//! NumPy `.npy` files through the `npyz` crate: float64 arrays written in C
//! order, and predictions read back with their dtype, order and shape
//! checked before any value is used.

use super::RunError;

/// The bytes of a little-endian float64 `.npy` of `shape` holding `data`
/// (row-major).
pub fn write(shape: &[usize], data: &[f64]) -> Result<Vec<u8>, RunError> {
    use npyz::WriterBuilder;
    debug_assert_eq!(shape.iter().product::<usize>(), data.len());
    let fail = |e: std::io::Error| RunError::BadPredictions { path: "(npy writer)".into(), reason: e.to_string() };
    let shape: Vec<u64> = shape.iter().map(|&d| d as u64).collect();
    let mut buf = Vec::with_capacity(data.len() * 8 + 128);
    let mut w =
        npyz::WriteOptions::<f64>::new().default_dtype().shape(&shape).writer(&mut buf).begin_nd().map_err(fail)?;
    w.extend(data.iter().copied()).map_err(fail)?;
    w.finish().map_err(fail)?;
    Ok(buf)
}

/// An array read from a `.npy`: its shape and values.
pub struct Array {
    /// The shape.
    pub shape: Vec<usize>,
    /// The values, row-major.
    pub data: Vec<f64>,
}

/// Reads `bytes` as a float64 array of `shape`, refusing (with what was
/// found and what is expected) anything but a little-endian `<f8` array
/// in C order of exactly that shape.
pub fn read(bytes: &[u8], shape: &[usize]) -> Result<Array, String> {
    let file = npyz::NpyFile::new(bytes).map_err(|e| format!("not a NumPy .npy file ({e})"))?;
    let dtype = match file.dtype() {
        npyz::DType::Plain(t) => t.to_string(),
        other => other.descr().to_string(),
    };
    if dtype != "<f8" {
        return Err(format!(
            "dtype {dtype}, expected <f8 (little-endian float64): write it with np.asarray(p, dtype='<f8')"
        ));
    }
    if file.order() != npyz::Order::C {
        return Err("Fortran order, expected C order: write it with np.ascontiguousarray(p)".into());
    }
    let found: Vec<usize> = file.shape().iter().map(|&d| d as usize).collect();
    if found != shape {
        return Err(format!("shape {found:?}, expected {shape:?} (starts x steps x state columns)"));
    }
    // The header's length field: 2 bytes in format 1.0, 4 in 2.0 and 3.0.
    let start = match bytes.get(6) {
        Some(1) => bytes.get(8..10).map(|b| 10 + usize::from(u16::from_le_bytes([b[0], b[1]]))),
        _ => bytes.get(8..12).map(|b| 12 + u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize),
    };
    let values = shape.iter().product::<usize>();
    if let Some(extra) = start.and_then(|h| bytes.len().checked_sub(h + values * 8)).filter(|&n| n > 0) {
        return Err(format!(
            "{extra} bytes after its {values} values: a file written over another, or two arrays in one; save one array with np.save"
        ));
    }
    let data: Vec<f64> = file.into_vec().map_err(|e| format!("cannot read its values ({e})"))?;
    if data.len() != values {
        return Err(format!("{} values, expected {values}", data.len()));
    }
    Ok(Array { shape: found, data })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bytes_after_the_declared_values_are_refused() {
        let bytes = write(&[2, 3], &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]).unwrap();
        assert_eq!(read(&bytes, &[2, 3]).unwrap().data, [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
        // A trust review (round 6): a file with bytes past its shape's
        // values was scored as if they were not there.
        let mut longer = bytes.clone();
        longer.extend_from_slice(&7.0f64.to_le_bytes());
        let Err(e) = read(&longer, &[2, 3]) else { panic!("read with 8 bytes more") };
        assert!(e.starts_with("8 bytes after its 6 values"), "{e}");
        // Cut short, its values are too few, as before.
        assert!(read(&bytes[..bytes.len() - 8], &[2, 3]).is_err());
    }
}

//! Where the networks train: the CPU (the reference, which every committed
//! result comes from) or an NVIDIA GPU through CUDA. The device is an
//! execution choice, recorded in `run.json` and in each job's record, never
//! part of a design's lock.
//!
//! A GPU is looked for before anything calls into CUDA: the driver's
//! library (`libcuda.so.1`) is opened at run time, and `cuInit`,
//! `cuDeviceGetCount` and `cuDeviceGetName` are asked for its first device.
//! A machine without the library, or without a device, is told what was
//! looked for; nothing panics there.
#![allow(unsafe_code)]

use std::ffi::{c_char, c_int, c_uint};
use std::fmt;
use std::str::FromStr;

/// The device a user asks for (`--device`); a Slurm array records it in
/// `array.json` (`cpu`, `cuda`, `auto`), and each task resolves it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DeviceChoice {
    /// The CPU trainer (the default; bit-identical to every committed run).
    #[default]
    Cpu,
    /// The CUDA trainer on the first NVIDIA GPU; refused where none is found.
    Cuda,
    /// The GPU where one is found, the CPU otherwise (and says so).
    Auto,
}

impl FromStr for DeviceChoice {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "cpu" => Ok(DeviceChoice::Cpu),
            "cuda" => Ok(DeviceChoice::Cuda),
            "auto" => Ok(DeviceChoice::Auto),
            other => Err(format!("unknown device `{other}`: expected cpu, cuda or auto")),
        }
    }
}

/// An NVIDIA GPU the driver reported.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Gpu {
    /// The device's ordinal (always 0: the first device).
    pub ordinal: usize,
    /// Its name, as the driver gives it (`NVIDIA H200`).
    pub name: String,
    /// The CUDA version the driver supports (`13.0`).
    pub driver: String,
}

/// The device a run trains on, once resolved.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub enum Device {
    /// The CPU trainer.
    #[default]
    Cpu,
    /// The CUDA trainer on this GPU.
    Cuda(Gpu),
}

impl fmt::Display for Device {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Device::Cpu => write!(f, "cpu"),
            Device::Cuda(g) => write!(f, "cuda: {} (device {}, CUDA driver {})", g.name, g.ordinal, g.driver),
        }
    }
}

impl Device {
    /// What a run records (`run.json`, job records): `None` for the CPU,
    /// which runs written before the device was recorded also used.
    pub fn record(&self) -> Option<String> {
        match self {
            Device::Cpu => None,
            Device::Cuda(_) => Some(self.to_string()),
        }
    }
}

/// Why no GPU can be used.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum DeviceError {
    /// No usable NVIDIA GPU was found.
    #[error("--device cuda: no usable NVIDIA GPU: {reason} (looked for {looked_for}); use --device cpu, or --device auto to train on the CPU where no GPU is found")]
    NoGpu {
        /// What was looked for.
        looked_for: String,
        /// What was found instead.
        reason: String,
    },
    /// This build has no CUDA trainer.
    #[error("--device cuda: this crossaudit was built without its CUDA trainer (cargo feature `cuda`); rebuild with the default features, or use --device cpu")]
    NotBuilt,
}

/// The names the driver's library goes by, tried in order.
const LIBRARIES: [&str; 2] = ["libcuda.so.1", "libcuda.so"];

/// The first NVIDIA GPU the driver reports, or why there is none.
pub fn probe() -> Result<Gpu, DeviceError> {
    let looked_for = format!("{} on the dynamic loader's path, then its first CUDA device", LIBRARIES.join(" or "));
    let no = |reason: String| DeviceError::NoGpu { looked_for: looked_for.clone(), reason };
    let mut tried = Vec::new();
    for name in LIBRARIES {
        // SAFETY: loading the NVIDIA driver's library runs only its own
        // initializers; no symbol is used unless found with the signature
        // the CUDA driver API documents.
        match unsafe { libloading::Library::new(name) } {
            Ok(lib) => return ask_driver(&lib).and_then(|g| libraries().map(|()| g)).map_err(no),
            Err(e) => {
                // The loader's own words name the file (`libcuda.so.1: cannot open ...`).
                tried.push(std::error::Error::source(&e).map_or_else(|| format!("{name}: {e}"), |s| s.to_string()));
            }
        }
    }
    Err(no(format!("the NVIDIA driver's library is not installed ({})", tried.join("; "))))
}

/// `cuInit`, the device count, the first device's name and the driver's
/// CUDA version, each with the CUDA driver API's own signature.
fn ask_driver(lib: &libloading::Library) -> Result<Gpu, String> {
    type Init = unsafe extern "C" fn(c_uint) -> c_int;
    type Count = unsafe extern "C" fn(*mut c_int) -> c_int;
    type Name = unsafe extern "C" fn(*mut c_char, c_int, c_int) -> c_int;
    type Version = unsafe extern "C" fn(*mut c_int) -> c_int;
    let missing = |what: &str, e: libloading::Error| format!("the driver's library has no {what}: {e}");
    // SAFETY: each symbol is looked up with the signature of the CUDA driver
    // API (cuda.h); every out-pointer points at a live local of the right type
    // and size, and the name buffer's length is passed with it.
    unsafe {
        let init: libloading::Symbol<Init> = lib.get(b"cuInit\0").map_err(|e| missing("cuInit", e))?;
        let count: libloading::Symbol<Count> =
            lib.get(b"cuDeviceGetCount\0").map_err(|e| missing("cuDeviceGetCount", e))?;
        let name: libloading::Symbol<Name> =
            lib.get(b"cuDeviceGetName\0").map_err(|e| missing("cuDeviceGetName", e))?;
        let version: libloading::Symbol<Version> =
            lib.get(b"cuDriverGetVersion\0").map_err(|e| missing("cuDriverGetVersion", e))?;
        let code = init(0);
        if code != 0 {
            return Err(format!("cuInit failed with CUDA error {code} ({})", cuda_error(code)));
        }
        let mut n: c_int = 0;
        let code = count(&mut n);
        if code != 0 || n < 1 {
            return Err(format!("the driver reports no CUDA device (cuDeviceGetCount: {n}, error {code})"));
        }
        let mut buf = [0 as c_char; 256];
        let code = name(buf.as_mut_ptr(), buf.len() as c_int, 0);
        if code != 0 {
            return Err(format!("cuDeviceGetName failed with CUDA error {code}"));
        }
        let bytes: Vec<u8> = buf.iter().take_while(|&&c| c != 0).map(|&c| c as u8).collect();
        let mut v: c_int = 0;
        let driver = if version(&mut v) == 0 { format!("{}.{}", v / 1000, (v % 1000) / 10) } else { "?".into() };
        Ok(Gpu { ordinal: 0, name: String::from_utf8_lossy(&bytes).into_owned(), driver })
    }
}

/// The CUDA libraries the trainer loads besides the driver's: cuBLAS and
/// NVRTC (found as cudarc looks for them, e.g. `libcublas.so.13`).
#[cfg(feature = "cuda")]
fn libraries() -> Result<(), String> {
    // SAFETY: each check only tries to open the library by its names.
    let found = unsafe {
        [("cuBLAS", cudarc::cublas::sys::is_culib_present()), ("NVRTC", cudarc::nvrtc::sys::is_culib_present())]
    };
    let missing: Vec<&str> = found.iter().filter(|(_, ok)| !ok).map(|(name, _)| *name).collect();
    if missing.is_empty() {
        return Ok(());
    }
    let names = cudarc::get_lib_name_candidates("cublas");
    Err(format!(
        "a GPU is there, but not the CUDA library of {} (looked for {} and the same names for nvrtc)",
        missing.join(" and "),
        names.join(", ")
    ))
}

/// Without the CUDA trainer nothing else is loaded.
#[cfg(not(feature = "cuda"))]
fn libraries() -> Result<(), String> {
    Ok(())
}

/// The names of the CUDA errors a probe meets.
fn cuda_error(code: c_int) -> &'static str {
    match code {
        3 => "CUDA_ERROR_NOT_INITIALIZED",
        35 => "CUDA_ERROR_INSUFFICIENT_DRIVER: the driver is older than the CUDA version it was asked for",
        100 => "CUDA_ERROR_NO_DEVICE: no CUDA-capable device is visible (CUDA_VISIBLE_DEVICES?)",
        101 => "CUDA_ERROR_INVALID_DEVICE",
        999 => "CUDA_ERROR_UNKNOWN",
        _ => "see cuda.h",
    }
}

/// The device `choice` resolves to on this machine, and what to tell the
/// user about it (`auto` that found no GPU says why it trains on the CPU).
pub fn resolve(choice: DeviceChoice) -> Result<(Device, Option<String>), DeviceError> {
    match choice {
        DeviceChoice::Cpu => Ok((Device::Cpu, None)),
        DeviceChoice::Cuda if !cfg!(feature = "cuda") => Err(DeviceError::NotBuilt),
        DeviceChoice::Cuda => probe().map(|g| (Device::Cuda(g), None)),
        DeviceChoice::Auto if !cfg!(feature = "cuda") => {
            Ok((Device::Cpu, Some("--device auto: training on the CPU (this build has no CUDA trainer)".into())))
        }
        DeviceChoice::Auto => match probe() {
            Ok(g) => {
                let d = Device::Cuda(g);
                let note = format!("--device auto: training on {d}");
                Ok((d, Some(note)))
            }
            Err(e) => Ok((Device::Cpu, Some(format!("--device auto: training on the CPU ({})", why(&e))))),
        },
    }
}

/// A probe's failure in a few words.
fn why(e: &DeviceError) -> String {
    match e {
        DeviceError::NoGpu { reason, .. } => format!("no usable NVIDIA GPU: {reason}"),
        DeviceError::NotBuilt => "this build has no CUDA trainer".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_choice_is_read_from_its_name() {
        assert_eq!("cpu".parse(), Ok(DeviceChoice::Cpu));
        assert_eq!("cuda".parse(), Ok(DeviceChoice::Cuda));
        assert_eq!("auto".parse(), Ok(DeviceChoice::Auto));
        let e = "gpu".parse::<DeviceChoice>().unwrap_err();
        assert!(e.contains("`gpu`") && e.contains("cpu, cuda or auto"), "{e}");
    }

    #[test]
    fn the_cpu_is_recorded_as_absent_and_a_gpu_by_name() {
        assert_eq!(Device::Cpu.record(), None);
        let g = Gpu { ordinal: 0, name: "NVIDIA H200".into(), driver: "13.0".into() };
        assert_eq!(Device::Cuda(g).record().as_deref(), Some("cuda: NVIDIA H200 (device 0, CUDA driver 13.0)"));
    }

    #[test]
    fn cuda_is_refused_and_auto_falls_back_where_no_gpu_is_found() -> Result<(), Box<dyn std::error::Error>> {
        // Only meaningful where the probe finds nothing (every CI machine);
        // on a GPU machine both resolve to the GPU.
        let Err(e) = probe() else { return Ok(()) };
        let DeviceError::NoGpu { looked_for, reason } = &e else { panic!("{e}") };
        assert!(looked_for.contains("libcuda.so.1"), "{looked_for}");
        assert!(!reason.is_empty());
        let msg = resolve(DeviceChoice::Cuda).unwrap_err().to_string();
        assert!(msg.starts_with("--device cuda: no usable NVIDIA GPU") && msg.contains("--device cpu"), "{msg}");
        let (d, note) = resolve(DeviceChoice::Auto)?;
        assert_eq!(d, Device::Cpu);
        assert!(note.is_some_and(|n| n.starts_with("--device auto: training on the CPU (no usable NVIDIA GPU")));
        Ok(())
    }
}

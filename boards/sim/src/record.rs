//! Recording of the frames masters send to a segment, for the fuzzers' seed corpora
//! (`tests-host/fuzz-targets`, `fuzz-seeds`).
//!
//! With `SIM_RECORD_FRAMES=<dir>` in the environment, every segment made in the process (in
//! process with ethercrab, or behind `sim-drive attach` for SOEM) writes
//! `<dir>/<pid>-<n>.frames`:
//!
//! | bytes | field |
//! |---|---|
//! | 8 | magic [`MAGIC`] |
//! | 4 | length of the SII image of the first drive (little-endian), then the image |
//! | then per frame: 8 | simulated time in ns at which the frame arrived |
//! | 2 | frame length, then the frame as the master sent it |
//!
//! Recording is off (and costs nothing) without the variable; a file that cannot be written
//! ends the recording of that segment, never the simulation.

use std::fs::File;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU32, Ordering};

/// The environment variable naming the directory to record into.
pub const RECORD_ENV: &str = "SIM_RECORD_FRAMES";
/// File magic.
pub const MAGIC: &[u8; 8] = b"SIMFRM01";

/// A recording in progress.
pub struct Recorder {
    file: Option<File>,
}

impl Recorder {
    /// Starts a recording if [`RECORD_ENV`] names a directory; `sii` identifies the drive.
    pub fn from_env(sii: &[u8]) -> Option<Self> {
        let dir = std::env::var_os(RECORD_ENV)?;
        Self::create(Path::new(&dir), sii)
    }

    fn create(dir: &Path, sii: &[u8]) -> Option<Self> {
        static NEXT: AtomicU32 = AtomicU32::new(0);
        let n = NEXT.fetch_add(1, Ordering::Relaxed);
        let path: PathBuf = dir.join(format!("{}-{n}.frames", std::process::id()));
        let mut file = File::create(path).ok()?;
        let len = u32::try_from(sii.len()).ok()?;
        file.write_all(MAGIC).ok()?;
        file.write_all(&len.to_le_bytes()).ok()?;
        file.write_all(sii).ok()?;
        Some(Self { file: Some(file) })
    }

    /// Records one frame arriving at `now_ns`.
    pub fn frame(&mut self, now_ns: u64, frame: &[u8]) {
        let Some(file) = self.file.as_mut() else {
            return;
        };
        let Ok(len) = u16::try_from(frame.len()) else {
            return;
        };
        let ok = file.write_all(&now_ns.to_le_bytes()).is_ok()
            && file.write_all(&len.to_le_bytes()).is_ok()
            && file.write_all(frame).is_ok();
        if !ok {
            self.file = None;
        }
    }
}

/// A recording read back: the first drive's SII image and the frames with their times.
pub struct Recording {
    /// SII image of the first drive.
    pub sii: Vec<u8>,
    /// (time in ns, frame).
    pub frames: Vec<(u64, Vec<u8>)>,
}

/// Parses a recording; `None` if it is not one (a truncated last frame is dropped).
pub fn parse(bytes: &[u8]) -> Option<Recording> {
    let rest = bytes.strip_prefix(MAGIC)?;
    let (len, rest) = rest.split_first_chunk::<4>()?;
    let len = usize::try_from(u32::from_le_bytes(*len)).ok()?;
    let sii = rest.get(..len)?.to_vec();
    let mut rest = rest.get(len..)?;
    let mut frames = Vec::new();
    while let Some((t, r)) = rest.split_first_chunk::<8>() {
        let Some((l, r)) = r.split_first_chunk::<2>() else {
            break;
        };
        let l = usize::from(u16::from_le_bytes(*l));
        let Some(frame) = r.get(..l) else { break };
        frames.push((u64::from_le_bytes(*t), frame.to_vec()));
        rest = &r[l..];
    }
    Some(Recording { sii, frames })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_recording_reads_back_as_written() {
        let dir = std::env::temp_dir().join(format!("sim-record-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mut r = Recorder::create(&dir, &[1, 2, 3, 4]).unwrap();
        r.frame(5, &[0xAA; 20]);
        r.frame(7, &[0xBB; 3]);
        drop(r);
        let file = std::fs::read_dir(&dir)
            .unwrap()
            .next()
            .unwrap()
            .unwrap()
            .path();
        let rec = parse(&std::fs::read(&file).unwrap()).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
        assert_eq!(rec.sii, [1, 2, 3, 4]);
        assert_eq!(rec.frames, vec![(5, vec![0xAA; 20]), (7, vec![0xBB; 3])]);
    }
}

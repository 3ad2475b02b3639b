//! The request and reply frames of the adjusting service (Σ-V-SD §4.5 (8) "Command/Reply data
//! format"): 16 bytes each, in the STRING(16) entries :01 (command) and :03 (reply).
//!
//! | byte | request | reply |
//! |---|---|---|
//! | 0 | reserved | status (as :02) |
//! | 1 | reserved | reserved |
//! | 2 | CCMD: 00h read, 01h write | RCMD: echo of CCMD |
//! | 3 | CSIZE: CDATA length in bytes | RSIZE: RDATA length in bytes |
//! | 4–7 | CADDRESS | RADDRESS: echo of CADDRESS |
//! | 8–15 | CDATA | RDATA |
//!
//! Multi-byte fields are little-endian (the manual does not say; EtherCAT and the Σ-V-SD's
//! objects are).

/// Length of a request and of a reply, bytes.
pub const FRAME_LEN: usize = 16;
/// Offsets of the fields (the table above).
const CCMD: usize = 2;
const CSIZE: usize = 3;
const CADDRESS: usize = 4;
const CDATA: usize = 8;
/// Longest CDATA / RDATA, bytes.
pub const MAX_DATA: usize = FRAME_LEN - CDATA;

/// CCMD: what the request does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Ccmd {
    /// 00h: read request.
    Read,
    /// 01h: write request.
    Write,
}

impl Ccmd {
    const READ: u8 = 0x00;
    const WRITE: u8 = 0x01;

    fn parse(b: u8) -> Option<Self> {
        match b {
            Self::READ => Some(Self::Read),
            Self::WRITE => Some(Self::Write),
            _ => None,
        }
    }

    const fn byte(self) -> u8 {
        match self {
            Self::Read => Self::READ,
            Self::Write => Self::WRITE,
        }
    }
}

/// Status (:02 and reply byte 0), §4.5 (8) table.
pub mod status {
    /// Last command completed, no errors, no response data.
    pub const DONE: u8 = 0;
    /// Last command completed, no errors, with response data ("status field will be returned
    /// to 1" for every accepted step).
    pub const DONE_WITH_DATA: u8 = 1;
    /// Last command completed with an error, no response data.
    pub const ERROR: u8 = 2;
    /// Last command completed with an error, with response data.
    pub const ERROR_WITH_DATA: u8 = 3;
    /// The command is executing.
    pub const EXECUTING: u8 = 255;
}

/// A decoded request.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Request {
    /// CCMD.
    pub command: Ccmd,
    /// CADDRESS.
    pub address: u32,
    /// CDATA as an unsigned little-endian number of CSIZE bytes (1, 2 or 4).
    pub data: u32,
}

/// Why a request frame could not be decoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FrameError {
    /// Fewer than the 16 bytes of a frame.
    Short,
    /// CCMD is neither 00h nor 01h.
    Command(u8),
    /// CSIZE is not 1, 2 or 4 (the service's data are 16-bit codes).
    Size(u8),
}

impl Request {
    /// Decodes the 16 request bytes.
    pub fn parse(frame: &[u8]) -> Result<Self, FrameError> {
        let frame: &[u8; FRAME_LEN] = frame
            .get(..FRAME_LEN)
            .and_then(|f| f.try_into().ok())
            .ok_or(FrameError::Short)?;
        let command = Ccmd::parse(frame[CCMD]).ok_or(FrameError::Command(frame[CCMD]))?;
        let size = frame[CSIZE];
        let mut data = [0u8; 4];
        match usize::from(size) {
            n @ (1 | 2 | 4) => copy_prefix(&mut data, frame.get(CDATA..).unwrap_or_default(), n),
            _ => return Err(FrameError::Size(size)),
        }
        let address = u32::from_le_bytes([
            frame[CADDRESS],
            frame[CADDRESS + 1],
            frame[CADDRESS + 2],
            frame[CADDRESS + 3],
        ]);
        Ok(Self {
            command,
            address,
            data: u32::from_le_bytes(data),
        })
    }

    /// The request frame (what a master writes; used by tests and tools).
    pub fn frame(&self, size: u8) -> [u8; FRAME_LEN] {
        let mut f = [0u8; FRAME_LEN];
        f[CCMD] = self.command.byte();
        f[CSIZE] = size;
        f[CADDRESS..CDATA].copy_from_slice(&self.address.to_le_bytes());
        let n = usize::from(size).min(4);
        if let Some(dst) = f.get_mut(CDATA..) {
            copy_prefix(dst, &self.data.to_le_bytes(), n);
        }
        f
    }
}

/// The reply frame: `status`; with an `echo` of the request, RCMD and RADDRESS repeat it and
/// RDATA holds `data` (RSIZE its length).
pub fn reply(status: u8, echo: Option<&Request>, data: &[u8]) -> [u8; FRAME_LEN] {
    let mut f = [0u8; FRAME_LEN];
    f[0] = status;
    if let Some(r) = echo {
        let n = data.len().min(MAX_DATA);
        f[CCMD] = r.command.byte();
        // n ≤ MAX_DATA = 8: fits a byte.
        f[CSIZE] = n as u8;
        f[CADDRESS..CDATA].copy_from_slice(&r.address.to_le_bytes());
        if let Some(dst) = f.get_mut(CDATA..) {
            copy_prefix(dst, data, n);
        }
    }
    f
}

/// Copies the first `n` bytes of `src` to the start of `dst` (fewer if either is shorter).
fn copy_prefix(dst: &mut [u8], src: &[u8], n: usize) {
    for (d, s) in dst.iter_mut().zip(src).take(n) {
        *d = *s;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_manuals_step_1_frame_decodes() {
        // Step 1: CCMD = 0001H, CADDRESS = 2000H, CSIZE = 0002H, CDATA = request code 100EH.
        let mut f = [0u8; FRAME_LEN];
        f[2] = 0x01;
        f[3] = 0x02;
        f[4..8].copy_from_slice(&0x2000u32.to_le_bytes());
        f[8..10].copy_from_slice(&0x100Eu16.to_le_bytes());
        f[10] = 0xAA; // beyond CSIZE: ignored
        let r = Request::parse(&f).unwrap();
        assert_eq!(
            r,
            Request {
                command: Ccmd::Write,
                address: 0x2000,
                data: 0x100E
            }
        );
        assert_eq!(Request::parse(&r.frame(2)).unwrap(), r);
    }

    #[test]
    fn malformed_frames_are_errors_not_panics() {
        assert_eq!(Request::parse(&[0; 15]), Err(FrameError::Short));
        let mut f = [0u8; FRAME_LEN];
        f[2] = 0x07;
        f[3] = 2;
        assert_eq!(Request::parse(&f), Err(FrameError::Command(7)));
        for size in [0u8, 3, 5, 8, 9, 255] {
            f[2] = 1;
            f[3] = size;
            assert_eq!(Request::parse(&f), Err(FrameError::Size(size)));
        }
    }

    #[test]
    fn reply_echoes_the_request_after_the_status() {
        let r = Request {
            command: Ccmd::Read,
            address: 0x2000,
            data: 0,
        };
        let f = reply(status::DONE_WITH_DATA, Some(&r), &0x1008u16.to_le_bytes());
        assert_eq!(f[0], 1);
        assert_eq!((f[2], f[3]), (0x00, 2));
        assert_eq!(&f[4..8], &0x2000u32.to_le_bytes());
        assert_eq!(&f[8..10], &0x1008u16.to_le_bytes());
        assert_eq!(reply(status::ERROR, None, &[1, 2]), {
            let mut e = [0u8; FRAME_LEN];
            e[0] = 2;
            e
        });
    }
}

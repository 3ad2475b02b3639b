//! A minimal CoE SDO client on raw mailbox datagrams (FPWR to SM0, FPRD from SM1) for what
//! ethercrab 0.7.1 does not do: SDO downloads of more than 4 bytes ("Only 4 byte SDO writes or
//! smaller are supported currently", `mailbox/coe/mod.rs`). Normal (non-segmented) download and
//! expedited or normal upload, ETG.1000.6 §5.6.2; the mailbox counter is 0 ("no counter",
//! ETG.1000.4: never a repeat), so requests interleave with ethercrab's own mailbox traffic.

use ethercrab::{Command, MainDevice};
use od_gen::model::Profile;

/// SM1 status register (SM n at 0x0800 + 8n, status at +5) and its "mailbox full" bit.
const SM1_STATUS: u16 = 0x0800 + 8 + 5;
const MAILBOX_FULL: u8 = 0x08;
/// Mailbox header: length u16, address u16, channel/priority u8, type | counter << 4 u8.
const MAILBOX_HEADER: usize = 6;
const TYPE_COE: u8 = 0x03;
/// CoE header (u16): service in bits 12–15.
const COE_SDO_REQUEST: u16 = 2 << 12;
const COE_SDO_RESPONSE: u16 = 3;
/// SDO command specifiers (ETG.1000.6 Table 42 ff.): download request with the size indicated
/// (normal), upload request, download response, abort; expedited upload response bit 1,
/// size-indicated bit 0, unused bytes in bits 2–3.
const CCS_DOWNLOAD_NORMAL: u8 = 0x21;
const CCS_UPLOAD: u8 = 0x40;
const SCS_DOWNLOAD: u8 = 0x60;
const SCS_UPLOAD: u8 = 0x40;
const SCS_ABORT: u8 = 0x80;
const SCS_MASK: u8 = 0xE0;
const EXPEDITED: u8 = 0x02;
/// Polls of SM1 before giving up (the simulated drive answers within the next frame).
const POLLS: usize = 50;

/// What went wrong.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum RawSdoError {
    /// The drive answered with an SDO abort of this code.
    Abort(u32),
    /// No response, or one that is not an SDO response to the request.
    Protocol(String),
}

/// An SDO client to the drive at `station` with the mailbox of `profile`.
pub struct RawSdo {
    station: u16,
    sm0: (u16, u16),
    sm1: (u16, u16),
}

impl RawSdo {
    /// For the drive at `station` whose SII mailbox layout is `profile`'s.
    pub fn new(profile: &Profile, station: u16) -> Self {
        Self {
            station,
            sm0: (profile.sm.mailbox_out.start, profile.sm.mailbox_out.length),
            sm1: (profile.sm.mailbox_in.start, profile.sm.mailbox_in.length),
        }
    }

    /// Normal SDO download of `data` to `index:subindex`.
    pub async fn download(
        &self,
        md: &MainDevice<'_>,
        index: u16,
        subindex: u8,
        data: &[u8],
    ) -> Result<(), RawSdoError> {
        let mut sdo = vec![CCS_DOWNLOAD_NORMAL];
        sdo.extend_from_slice(&index.to_le_bytes());
        sdo.push(subindex);
        sdo.extend_from_slice(&(data.len() as u32).to_le_bytes());
        sdo.extend_from_slice(data);
        let r = self.exchange(md, &sdo).await?;
        match r.first().map(|c| c & SCS_MASK) {
            Some(SCS_DOWNLOAD) => Ok(()),
            _ => Err(RawSdoError::Protocol(format!("download response {r:02x?}"))),
        }
    }

    /// SDO upload of `index:subindex` (expedited or normal response).
    pub async fn upload(
        &self,
        md: &MainDevice<'_>,
        index: u16,
        subindex: u8,
    ) -> Result<Vec<u8>, RawSdoError> {
        let mut sdo = vec![CCS_UPLOAD];
        sdo.extend_from_slice(&index.to_le_bytes());
        sdo.push(subindex);
        sdo.extend_from_slice(&[0; 4]);
        let r = self.exchange(md, &sdo).await?;
        let bad = || RawSdoError::Protocol(format!("upload response {r:02x?}"));
        let c = *r.first().ok_or_else(bad)?;
        if c & SCS_MASK != SCS_UPLOAD {
            return Err(bad());
        }
        if c & EXPEDITED != 0 {
            let unused = usize::from((c >> 2) & 0x03);
            return Ok(r.get(4..8 - unused).ok_or_else(bad)?.to_vec());
        }
        let len = u32::from_le_bytes(r.get(4..8).ok_or_else(bad)?.try_into().map_err(|_| bad())?);
        Ok(r.get(8..8 + len as usize).ok_or_else(bad)?.to_vec())
    }

    /// Sends one CoE SDO request and returns the SDO part of the response (an abort becomes
    /// [`RawSdoError::Abort`]).
    async fn exchange(&self, md: &MainDevice<'_>, sdo: &[u8]) -> Result<Vec<u8>, RawSdoError> {
        let mut frame = vec![0u8; usize::from(self.sm0.1)];
        let coe_len = 2 + sdo.len();
        frame[0..2].copy_from_slice(&(coe_len as u16).to_le_bytes());
        frame[5] = TYPE_COE; // counter 0
        frame[MAILBOX_HEADER..MAILBOX_HEADER + 2].copy_from_slice(&COE_SDO_REQUEST.to_le_bytes());
        frame[MAILBOX_HEADER + 2..MAILBOX_HEADER + coe_len].copy_from_slice(sdo);
        // The whole SM0 buffer: writing its last byte hands it to the drive.
        Command::fpwr(self.station, self.sm0.0)
            .send(md, frame.as_slice())
            .await
            .map_err(|e| RawSdoError::Protocol(format!("SM0 write: {e:?}")))?;
        for _ in 0..POLLS {
            let status: u8 = Command::fprd(self.station, SM1_STATUS)
                .receive(md)
                .await
                .map_err(|e| RawSdoError::Protocol(format!("SM1 status: {e:?}")))?;
            if status & MAILBOX_FULL == 0 {
                continue;
            }
            // The whole SM1 buffer: reading its last byte frees it.
            let data = Command::fprd(self.station, self.sm1.0)
                .receive_slice(md, self.sm1.1)
                .await
                .map_err(|e| RawSdoError::Protocol(format!("SM1 read: {e:?}")))?;
            let data = data.to_vec();
            if data.get(5).map(|t| t & 0x0F) != Some(TYPE_COE) {
                continue; // another mailbox protocol's message
            }
            let coe = u16::from_le_bytes([data[MAILBOX_HEADER], data[MAILBOX_HEADER + 1]]);
            if coe >> 12 != COE_SDO_RESPONSE && coe >> 12 != COE_SDO_REQUEST >> 12 {
                continue; // an emergency
            }
            let len = usize::from(u16::from_le_bytes([data[0], data[1]]));
            let sdo = data
                .get(MAILBOX_HEADER + 2..MAILBOX_HEADER + len)
                .unwrap_or(&[])
                .to_vec();
            if sdo.first() == Some(&SCS_ABORT) {
                let code = sdo
                    .get(4..8)
                    .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
                    .unwrap_or(0);
                return Err(RawSdoError::Abort(code));
            }
            return Ok(sdo);
        }
        Err(RawSdoError::Protocol("no response in SM1".into()))
    }
}

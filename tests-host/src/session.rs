//! Master sessions against a drive that outlives them: connect a fresh ethercrab master to a
//! segment, bring drive 0 to PRE-OP, run SDO steps, and hand the segment back so that the test
//! can power-cycle the drive (its parameter storage stays) and connect again.

use board_sim::inproc::InProcess;
use board_sim::Segment;
use ethercrab::error::Error;
use ethercrab::Command;

use crate::{block_on, master_for, FIRST_STATION};

/// What one master session does with drive 0 in PRE-OP.
#[derive(Clone, Copy, Debug)]
pub enum Step {
    /// SDO download of a u32 (the entry's length: the value is sent as 4 bytes, so only
    /// 32-bit entries).
    Write(u16, u8, u32),
    /// SDO download of a u16 (16-bit entries).
    WriteU16(u16, u8, u16),
    /// SDO upload as a u32.
    Read(u16, u8),
    /// SDO upload of a 16-bit entry.
    ReadU16(u16, u8),
    /// FPRD of a 16-bit ESC register of drive 0.
    Register(u16),
}

/// Takes the segment away from a master (which is then done with it).
pub fn take_segment(m: &InProcess) -> Segment {
    let empty = Segment::new("standard", 0).expect("empty segment");
    std::mem::replace(&mut *m.shared.segment(), empty)
}

/// Switches drive 0 off and on; its storage stays. Panics if the stored parameters could not
/// be read back.
pub fn power_cycle(segment: &mut Segment) {
    let drive = &mut segment.drives_mut()[0];
    drive.power_cycle().expect("power cycle");
    assert!(drive.loaded.is_ok(), "storage readable: {:?}", drive.loaded);
}

/// Connects a fresh master to `segment`, brings the drive to PRE-OP, runs `steps` and returns
/// the segment with each step's outcome (a read's value, or a write's result).
pub fn session(segment: Segment, steps: &[Step]) -> (Segment, Vec<Result<u32, Error>>) {
    block_on(async {
        let (m, transport) = master_for(segment);
        let transport = tokio::task::spawn_local(transport);
        let md = &*m.maindevice;
        let group = md
            .init_single_group::<4, 64>(m.shared.clock().now_fn())
            .await
            .expect("init to PRE-OP");
        let sd = group.iter(md).next().expect("one drive");
        let mut out = Vec::new();
        for step in steps {
            out.push(match *step {
                Step::Write(index, sub, value) => sd.sdo_write(index, sub, value).await.map(|()| 0),
                Step::WriteU16(index, sub, value) => {
                    sd.sdo_write(index, sub, value).await.map(|()| 0)
                }
                Step::Read(index, sub) => sd.sdo_read::<u32>(index, sub).await,
                Step::ReadU16(index, sub) => sd.sdo_read::<u16>(index, sub).await.map(u32::from),
                Step::Register(address) => Command::fprd(FIRST_STATION, address)
                    .receive::<u16>(md)
                    .await
                    .map(u32::from),
            });
        }
        let segment = take_segment(&m);
        drop(group);
        transport.abort();
        (segment, out)
    })
}

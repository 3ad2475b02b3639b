//! Digital outputs 60FEh (CiA402): sub 1 "physical outputs" holds a level for each output, sub 2
//! "bit mask" says which outputs the master forces to that level; the others the drive drives
//! itself. Bit 0 is the holding brake ("set brake": 1 = applied), bits 16–31 the
//! manufacturer's outputs (a GHA-E's DO1–DO6 at bits 16–21, an RSE's OUT1–OUT4 at 16–19).

/// Bit 0: set brake (1 = the brake holds the motor).
pub const BRAKE: u32 = 1 << 0;

/// The output levels: the master's level where its mask forces an output, the drive's own level
/// elsewhere. The drive applies the holding brake unless the power stage runs (`running`).
pub fn levels(physical: u32, mask: u32, running: bool) -> u32 {
    let own = if running { 0 } else { BRAKE };
    (physical & mask) | (own & !mask)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_mask_chooses_between_the_masters_level_and_the_drives() {
        const DO1: u32 = 1 << 16;
        const DO2: u32 = 1 << 17;
        // GHA-E §5.7.4 2): on only where both sub 1 and sub 2 have the bit.
        assert_eq!(levels(DO1 | DO2, DO1, true), DO1);
        assert_eq!(levels(DO1, DO1 | DO2, true), DO1);
        assert_eq!(levels(DO1, 0, true), 0, "not forced: the drive's (off)");
        // The brake: applied while the power stage is off, released while it runs.
        assert_eq!(levels(0, 0, false), BRAKE);
        assert_eq!(levels(0, 0, true), 0);
        // Forced by the master either way.
        assert_eq!(levels(0, BRAKE, false), 0, "forced released");
        assert_eq!(levels(BRAKE, BRAKE, true), BRAKE, "forced applied");
    }
}

//! FMMU registers (0x0600 + 16·n).

/// FMMU type byte (offset 11): which logical datagrams the FMMU serves.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FmmuType(pub u8);

impl FmmuType {
    /// Bit 0: logical read access is mapped (ESC memory → frame).
    pub const READ: u8 = 1 << 0;
    /// Bit 1: logical write access is mapped (frame → ESC memory).
    pub const WRITE: u8 = 1 << 1;

    /// Serves logical reads.
    pub const fn read(self) -> bool {
        self.0 & Self::READ != 0
    }
    /// Serves logical writes.
    pub const fn write(self) -> bool {
        self.0 & Self::WRITE != 0
    }
}

/// The 16 bytes of one FMMU.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FmmuConfig {
    /// Logical start address.
    pub logical_start: u32,
    /// Length in bytes of the logical window (first to last byte touched).
    pub length: u16,
    /// First bit (0..7) of the first logical byte.
    pub logical_start_bit: u8,
    /// Last bit (0..7) of the last logical byte.
    pub logical_end_bit: u8,
    /// Physical start address.
    pub physical_start: u16,
    /// First bit (0..7) of the first physical byte.
    pub physical_start_bit: u8,
    /// Read/write type.
    pub kind: FmmuType,
    /// Activate bit 0.
    pub active: bool,
}

impl FmmuConfig {
    /// Size of the register block.
    pub const LEN: usize = 16;

    /// Decodes the 16-byte register block.
    pub const fn from_bytes(b: [u8; 16]) -> Self {
        Self {
            logical_start: u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
            length: u16::from_le_bytes([b[4], b[5]]),
            logical_start_bit: b[6] & 0x07,
            logical_end_bit: b[7] & 0x07,
            physical_start: u16::from_le_bytes([b[8], b[9]]),
            physical_start_bit: b[10] & 0x07,
            kind: FmmuType(b[11]),
            active: b[12] & 0x01 != 0,
        }
    }
    /// Encodes the 16-byte register block.
    pub const fn to_bytes(self) -> [u8; 16] {
        let ls = self.logical_start.to_le_bytes();
        let l = self.length.to_le_bytes();
        let ps = self.physical_start.to_le_bytes();
        [
            ls[0],
            ls[1],
            ls[2],
            ls[3],
            l[0],
            l[1],
            self.logical_start_bit,
            self.logical_end_bit,
            ps[0],
            ps[1],
            self.physical_start_bit,
            self.kind.0,
            self.active as u8,
            0,
            0,
            0,
        ]
    }
}

//! ARM semihosting, the calls the benchmark needs: print a string, read its command line and a
//! host file, and exit with a status.
//!
//! On M-profile cores a semihosting call is `BKPT 0xAB` with the operation number in r0 and its
//! parameter in r1; the result comes back in r0 ("Semihosting for AArch32 and AArch64", Arm,
//! §2.1.1 and §6). QEMU serves the calls with `-semihosting-config enable=on,target=native`.

use core::arch::asm;
use core::fmt;

/// SYS_WRITE0: writes a NUL-terminated string to the debug console; r1 = its address.
const SYS_WRITE0: usize = 0x04;
/// SYS_OPEN: opens a host file; r1 = address of a block {name address, mode, name length};
/// returns a handle, or −1.
const SYS_OPEN: usize = 0x01;
/// SYS_OPEN mode "r" (ISO C `fopen` modes in the order of the semihosting specification).
const OPEN_MODE_READ: usize = 0;
/// SYS_READ: reads from a handle; r1 = address of a block {handle, buffer address, length};
/// returns the number of bytes *not* read (equal to the length at the end of the file).
const SYS_READ: usize = 0x06;
/// SYS_GET_CMDLINE: copies the command line (QEMU: the `-kernel` file name, then the `-append`
/// text) into a buffer; r1 = address of a block {buffer address, buffer length}, the length
/// comes back as the bytes written.
const SYS_GET_CMDLINE: usize = 0x15;
/// SYS_EXIT: ends the program; on AArch32 r1 is the reason code itself.
const SYS_EXIT: usize = 0x18;
/// Reason code of SYS_EXIT for a normal end; QEMU exits with status 0.
const ADP_STOPPED_APPLICATION_EXIT: usize = 0x2_0026;
/// Reason code of SYS_EXIT for a run-time error; QEMU exits with status 1.
const ADP_STOPPED_RUN_TIME_ERROR_UNKNOWN: usize = 0x2_0023;

/// Bytes of text per SYS_WRITE0 call (one trap per chunk; the last byte holds the NUL).
const CHUNK: usize = 128;

/// One semihosting call.
///
/// # Safety
/// `arg` must be what the operation `op` expects (for SYS_WRITE0 the address of a
/// NUL-terminated string that stays valid during the call).
unsafe fn call(op: usize, arg: usize) -> usize {
    let mut r0 = op;
    // SAFETY: the caller guarantees `arg`; the host reads memory only (no `nomem`, so the
    // compiler keeps the string in memory before the trap).
    unsafe { asm!("bkpt #0xab", inout("r0") r0, in("r1") arg, options(nostack, preserves_flags)) };
    r0
}

/// A host file read byte by byte (through a small buffer).
pub struct HostFile {
    handle: usize,
    buf: [u8; 64],
    len: usize,
    at: usize,
}

impl HostFile {
    /// Opens the host file `path` for reading, or `None`.
    pub fn open(path: &str) -> Option<Self> {
        // The host wants a NUL-terminated name (and its length without the NUL).
        let mut name = [0u8; 256];
        name.get_mut(..path.len())?.copy_from_slice(path.as_bytes());
        if path.len() >= name.len() {
            return None;
        }
        let block = [name.as_ptr() as usize, OPEN_MODE_READ, path.len()];
        // SAFETY: `block` names a NUL-terminated name of the stated length; both outlive the
        // call.
        let handle = unsafe { call(SYS_OPEN, block.as_ptr() as usize) };
        (handle != usize::MAX).then_some(Self {
            handle,
            buf: [0; 64],
            len: 0,
            at: 0,
        })
    }

    /// The next byte, or `None` at the end of the file (or on an error).
    pub fn read_byte(&mut self) -> Option<u8> {
        if self.at == self.len {
            let block = [self.handle, self.buf.as_mut_ptr() as usize, self.buf.len()];
            // SAFETY: `block` names this file's handle and a writable buffer of the stated
            // length; both outlive the call.
            let not_read = unsafe { call(SYS_READ, block.as_ptr() as usize) };
            self.len = self.buf.len().checked_sub(not_read)?;
            self.at = 0;
        }
        let byte = *self.buf.get(self.at)?;
        self.at += 1;
        Some(byte)
    }
}

/// The words of the command line after the program's own name, in a buffer of their own.
pub struct Arguments {
    buf: [u8; 256],
    len: usize,
}

impl Arguments {
    /// The command line (empty if the host gives none).
    pub fn get() -> Self {
        let mut args = Self {
            buf: [0; 256],
            len: 0,
        };
        let mut block = [args.buf.as_mut_ptr() as usize, args.buf.len()];
        // SAFETY: `block` names a writable buffer of its stated length; both outlive the call.
        let status = unsafe { call(SYS_GET_CMDLINE, block.as_mut_ptr() as usize) };
        if status == 0 {
            args.len = block[1].min(args.buf.len());
        }
        args
    }

    /// The words after the program's name.
    pub fn words(&self) -> impl Iterator<Item = &str> {
        let line = self
            .buf
            .get(..self.len)
            .and_then(|b| core::str::from_utf8(b).ok())
            .unwrap_or("");
        line.split_ascii_whitespace().skip(1)
    }
}

/// Ends the program: exit status 0 if `success`, else 1.
pub fn exit(success: bool) -> ! {
    let reason = if success {
        ADP_STOPPED_APPLICATION_EXIT
    } else {
        ADP_STOPPED_RUN_TIME_ERROR_UNKNOWN
    };
    // SAFETY: SYS_EXIT takes the reason code by value.
    unsafe { call(SYS_EXIT, reason) };
    // Only reached without a semihosting host (which would have trapped on the BKPT instead).
    cortex_m::asm::udf()
}

/// The host's console as a [`fmt::Write`]: text is buffered and sent in chunks of
/// [`CHUNK`] − 1 bytes, and at every newline.
pub struct Console {
    buf: [u8; CHUNK],
    len: usize,
}

impl Console {
    /// An empty console buffer.
    pub const fn new() -> Self {
        Self {
            buf: [0; CHUNK],
            len: 0,
        }
    }

    /// Sends the buffered text.
    pub fn flush(&mut self) {
        if self.len == 0 {
            return;
        }
        self.buf[self.len] = 0;
        // SAFETY: `buf` is NUL-terminated at `len` and outlives the call.
        unsafe { call(SYS_WRITE0, self.buf.as_ptr() as usize) };
        self.len = 0;
    }
}

impl Default for Console {
    fn default() -> Self {
        Self::new()
    }
}

impl fmt::Write for Console {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        for &byte in s.as_bytes() {
            // A NUL would end the string early on the host; the benchmark never prints one.
            let byte = if byte == 0 { b'?' } else { byte };
            self.buf[self.len] = byte;
            self.len += 1;
            if byte == b'\n' || self.len == CHUNK - 1 {
                self.flush();
            }
        }
        Ok(())
    }
}

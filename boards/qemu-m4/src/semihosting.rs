//! ARM semihosting, the two calls the benchmark needs: print a string and exit with a status.
//!
//! On M-profile cores a semihosting call is `BKPT 0xAB` with the operation number in r0 and its
//! parameter in r1; the result comes back in r0 ("Semihosting for AArch32 and AArch64", Arm,
//! §2.1.1 and §6). QEMU serves the calls with `-semihosting-config enable=on,target=native`.

use core::arch::asm;
use core::fmt;

/// SYS_WRITE0: writes a NUL-terminated string to the debug console; r1 = its address.
const SYS_WRITE0: usize = 0x04;
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

//! Which bytes of an OD RAM copy were written: what the ESC-event context, working on its own
//! copy of the OD RAM, hands back to the process-data side (see `crate::slave::mailbox_side`).

use core::ops::Range;

/// Largest OD RAM whose writes can be tracked, in bytes (the slave refuses a larger RAM; the
/// largest profile's is some 2.3 KiB). The map takes one bit per byte of it.
pub const MAX_TRACKED_RAM: usize = 4096;
const BITS: usize = u32::BITS as usize;
const WORDS: usize = MAX_TRACKED_RAM / BITS;
// The marked words' bounds are kept as u16.
const _: () = assert!(WORDS <= u16::MAX as usize);

/// One bit per OD RAM byte: set when [`super::Dictionary::set_value`] wrote it.
///
/// The map also keeps the range of words that hold marks, so that clearing it and copying the
/// marked bytes visit only those words (an event round writes one entry; the ESC-event round
/// clears and copies under the lock the SYNC0 interrupt shares).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DirtyMap {
    words: [u32; WORDS],
    /// Every word with a mark lies in `first..end` (`first == end`: no marks).
    first: u16,
    end: u16,
}

impl Default for DirtyMap {
    fn default() -> Self {
        Self::new()
    }
}

impl DirtyMap {
    /// Nothing written.
    pub const fn new() -> Self {
        Self {
            words: [0; WORDS],
            first: 0,
            end: 0,
        }
    }

    /// Marks `bytes` written (bytes beyond [`MAX_TRACKED_RAM`] are not tracked; the slave
    /// refuses a larger RAM).
    pub fn mark(&mut self, bytes: Range<usize>) {
        let end = bytes.end.min(MAX_TRACKED_RAM);
        let Some(last) = end.checked_sub(1).filter(|&last| last >= bytes.start) else {
            return; // nothing within the tracked size
        };
        for b in bytes.start..end {
            if let Some(w) = self.words.get_mut(b / BITS) {
                *w |= 1 << (b % BITS);
            }
        }
        // Both below WORDS ≤ u16::MAX (the assertion above), the end at most WORDS.
        let (first, past) = (
            (bytes.start / BITS) as u16,
            (last / BITS).wrapping_add(1) as u16,
        );
        if self.first == self.end {
            (self.first, self.end) = (first, past);
        } else {
            (self.first, self.end) = (self.first.min(first), self.end.max(past));
        }
    }

    /// Whether anything was written.
    pub fn any(&self) -> bool {
        self.marked_words().iter().any(|&w| w != 0)
    }

    /// Forgets every mark (visits only the words that may hold one).
    pub fn clear(&mut self) {
        let span = self.span();
        if let Some(words) = self.words.get_mut(span) {
            words.fill(0);
        }
        (self.first, self.end) = (0, 0);
    }

    /// The words that may hold marks.
    fn span(&self) -> Range<usize> {
        usize::from(self.first)..usize::from(self.end)
    }

    fn marked_words(&self) -> &[u32] {
        self.words.get(self.span()).unwrap_or(&[])
    }

    /// Copies every marked byte of `from` to `to` (same layout), then clears the marks. Only the
    /// words that hold marks are visited, so the work is bounded by what was written, not by
    /// the RAM or [`MAX_TRACKED_RAM`]; marked bytes outside `from` or `to` are skipped.
    pub fn copy_marked(&mut self, from: &[u8], to: &mut [u8]) {
        let span = self.span();
        (self.first, self.end) = (0, 0);
        let Some(words) = self.words.get_mut(span.clone()) else {
            return;
        };
        for (index, word) in span.zip(words.iter_mut()) {
            let mut w = core::mem::take(word);
            // index < WORDS: the byte offsets stay below MAX_TRACKED_RAM.
            let base = index.wrapping_mul(BITS);
            while w != 0 {
                let at = base.wrapping_add(w.trailing_zeros() as usize);
                // Clears the lowest mark (w ≠ 0).
                w &= w.wrapping_sub(1);
                if let (Some(&v), Some(d)) = (from.get(at), to.get_mut(at)) {
                    *d = v;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    extern crate std;
    use std::vec;
    use std::vec::Vec;

    #[test]
    fn only_marked_bytes_are_copied_and_the_marks_clear() {
        let mut d = DirtyMap::new();
        assert!(!d.any());
        d.mark(2..4);
        d.mark(40..41);
        assert!(d.any());
        let from = [0xAAu8; 64];
        let mut to = [0u8; 64];
        d.copy_marked(&from, &mut to);
        for (i, &b) in to.iter().enumerate() {
            let expected = if (2..4).contains(&i) || i == 40 {
                0xAA
            } else {
                0
            };
            assert_eq!(b, expected, "byte {i}");
        }
        assert!(!d.any(), "copying clears the marks");
    }

    #[test]
    fn marks_beyond_the_tracked_size_or_the_slices_are_ignored() {
        let mut d = DirtyMap::new();
        d.mark(MAX_TRACKED_RAM - 1..MAX_TRACKED_RAM + 10);
        let from = [1u8; 8];
        let mut to = [0u8; 8];
        d.copy_marked(&from, &mut to);
        assert_eq!(to, [0; 8]);
        assert!(!d.any(), "copying clears the marks outside the slices too");
    }

    #[test]
    fn marks_far_apart_are_all_copied_and_cleared() {
        let mut d = DirtyMap::new();
        d.mark(3000..3004);
        d.mark(5..6);
        d.mark(1000..1002);
        let from: Vec<u8> = (0..MAX_TRACKED_RAM).map(|i| (i % 251) as u8 + 1).collect();
        let mut to = vec![0u8; MAX_TRACKED_RAM];
        d.copy_marked(&from, &mut to);
        for (i, &b) in to.iter().enumerate() {
            let marked = (3000..3004).contains(&i) || i == 5 || (1000..1002).contains(&i);
            assert_eq!(b, if marked { from[i] } else { 0 }, "byte {i}");
        }
        assert!(!d.any());
        // Nothing left behind for the next round.
        let mut again = vec![0u8; MAX_TRACKED_RAM];
        d.copy_marked(&from, &mut again);
        assert!(again.iter().all(|&b| b == 0));
    }

    #[test]
    fn clearing_forgets_every_mark() {
        let mut d = DirtyMap::new();
        d.mark(0..1);
        d.mark(MAX_TRACKED_RAM - 2..MAX_TRACKED_RAM);
        assert!(d.any());
        d.clear();
        assert!(!d.any());
        let from = vec![7u8; MAX_TRACKED_RAM];
        let mut to = vec![0u8; MAX_TRACKED_RAM];
        d.copy_marked(&from, &mut to);
        assert!(to.iter().all(|&b| b == 0));
        assert_eq!(d, DirtyMap::new());
    }

    #[test]
    fn empty_and_untracked_ranges_mark_nothing() {
        let mut d = DirtyMap::new();
        d.mark(10..10);
        d.mark(MAX_TRACKED_RAM..MAX_TRACKED_RAM + 4);
        assert!(!d.any());
        assert_eq!(d, DirtyMap::new());
    }
}

//! The line levels a UART drives, rebuilt from characters: what a logic analyser on the wire
//! would have sampled.
//!
//! A character frame is one start bit, 7 or 8 data bits, the parity bit if any, and 1 or 2
//! stop bits ([ET200S SI] §2.6, Figures 2-8 and 2-9). The line idles high (mark), the start bit
//! is low (space), the stop bits high, and the data go least significant bit first, as on every
//! UART (`[derived]`: the manual's drawings of the bit order are lost). The levels are sampled at [`SAMPLES_PER_BIT`]
//! samples per bit, so every bit is exactly that many samples long and a decoder's mid-bit
//! sample point falls on a clean level.
//!
//! Input is a time-ordered sequence of [`LineItem`]s (characters by their start, and level
//! changes of control lines such as RTS); output is the [`Edge`]s in sample order. Only the
//! edges of characters still on the line are held, a dozen per channel at most.

use si_core::sansio::LineError;
use si_core::serial::{Parity, SerialSettings};
use si_core::Instant;
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// Samples per bit: 16, the oversampling of a UART receiver, so PulseView shows every bit as a
/// level with room for its decoder's sample point.
pub const SAMPLES_PER_BIT: u64 = 16;

/// The sample rate for a line: [`SAMPLES_PER_BIT`] × the baud rate (153 600 Hz at 9600 bit/s,
/// 3 MHz at USS's 187 500 bit/s).
pub fn sample_rate(settings: &SerialSettings) -> u64 {
    u64::from(settings.baud()) * SAMPLES_PER_BIT
}

/// Idle line before trace time 0, in character times: a decoder finds a start bit only after a
/// falling edge, so a character at time 0 needs quiet line before it. Sample 0 of a waveform is
/// this much before the trace's time 0.
pub const LEAD_IN_CHARS: u64 = 2;

/// One thing on the line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LineItem {
    /// A character whose start bit begins at `start`, driven on `channel`; an error stands for
    /// what a receiver reported instead of a character (see [`char_bits`]).
    Char {
        /// Beginning of the start bit.
        start: Instant,
        /// The channel it is drawn on.
        channel: usize,
        /// The character, or the receiver's error.
        item: Result<u8, LineError>,
    },
    /// A control line (RTS) changes to `high` at `at`.
    Level {
        /// When.
        at: Instant,
        /// The channel.
        channel: usize,
        /// The new level.
        high: bool,
    },
}

impl LineItem {
    fn at(&self) -> Instant {
        match *self {
            LineItem::Char { start, .. } => start,
            LineItem::Level { at, .. } => at,
        }
    }
}

/// A level change of one channel at one sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Edge {
    /// Sample index (0 is [`LEAD_IN_CHARS`] character times before trace time 0).
    pub sample: u64,
    /// The channel.
    pub channel: usize,
    /// The level from this sample on.
    pub high: bool,
}

/// The bits of one character frame, first on the line in bit 0, and how many there are.
///
/// Errors have no character value; they are drawn so a decoder reports the same error
/// (`[derived]`, the receiver's report is all a trace keeps):
/// - parity: data 00H with the parity bit wrong;
/// - framing: data 00H with the stop bits low;
/// - BREAK: the whole character time low;
/// - overrun: nothing (the lost character's time is unknown), `None`.
pub fn char_bits(settings: &SerialSettings, item: Result<u8, LineError>) -> Option<(u32, u32)> {
    let data_bits = u32::from(settings.data_bits());
    let n = settings.bits_per_char();
    let (value, parity_wrong, stop_low) = match item {
        Ok(b) => (u32::from(b) & ((1 << data_bits) - 1), false, false),
        Err(LineError::Parity) => (0, true, false),
        Err(LineError::Framing) => (0, false, true),
        Err(LineError::Break) => return Some((0, n)),
        Err(LineError::Overrun) => return None,
    };
    let ones = value.count_ones();
    let parity = match settings.parity() {
        Parity::None => None,
        Parity::Even => Some(ones % 2 == 1),
        Parity::Odd => Some(ones % 2 == 0),
        Parity::Mark => Some(true),
        Parity::Space => Some(false),
    };
    // Start bit 0 at bit 0, data at 1..=data_bits.
    let mut bits = value << 1;
    let mut k = 1 + data_bits;
    if let Some(p) = parity {
        if p != parity_wrong {
            bits |= 1 << k;
        }
        k += 1;
    }
    if !stop_low {
        for _ in 0..settings.stop_bits() {
            bits |= 1 << k;
            k += 1;
        }
    }
    Some((bits, n))
}

/// Turns line items into edges, in sample order.
#[derive(Debug)]
pub struct Levels {
    settings: SerialSettings,
    rate: u64,
    /// Edges not yet released: (sample, order of arrival, channel, level).
    pending: BinaryHeap<Reverse<(u64, u64, usize, bool)>>,
    seq: u64,
    /// Per channel: the level last released, and the sample its last character ends.
    level: Vec<bool>,
    busy_until: Vec<u64>,
    /// No item may start before this sample (the latest item start seen): keeps the edges in
    /// order when a trace's times step back.
    floor: u64,
    /// Sample of the last released edge.
    last: u64,
}

impl Levels {
    /// A rebuilder for a line of `settings` whose channels start at the levels `initial`
    /// (UART lines idle high, RTS as recorded, else low).
    pub fn new(settings: SerialSettings, initial: Vec<bool>) -> Self {
        let n = initial.len();
        Levels {
            settings,
            rate: sample_rate(&settings),
            pending: BinaryHeap::new(),
            seq: 0,
            level: initial,
            busy_until: vec![0; n],
            floor: 0,
            last: 0,
        }
    }

    /// Samples of idle line before trace time 0 ([`LEAD_IN_CHARS`]).
    pub fn lead_in(&self) -> u64 {
        LEAD_IN_CHARS * u64::from(self.settings.bits_per_char()) * SAMPLES_PER_BIT
    }

    /// Sample index of instant `at` (rounded down), after the lead-in.
    pub fn sample_of(&self, at: Instant) -> u64 {
        let s = u128::from(at.as_micros()) * u128::from(self.rate) / 1_000_000;
        u64::try_from(s)
            .unwrap_or(u64::MAX)
            .saturating_add(self.lead_in())
    }

    /// Take one item; edges that can no longer be preceded by a later item go to `out`.
    /// A channel index out of range is ignored.
    pub fn push(&mut self, item: LineItem, out: &mut impl FnMut(Edge)) {
        let at = self.sample_of(item.at()).max(self.floor);
        self.floor = at;
        self.release_before(at, out);
        match item {
            LineItem::Char { channel, item, .. } => {
                let Some(&free) = self.busy_until.get(channel) else {
                    return;
                };
                let Some((bits, n)) = char_bits(&self.settings, item) else {
                    return;
                };
                // A character waits for the one before it on its channel.
                let start = at.max(free);
                let end = start + u64::from(n) * SAMPLES_PER_BIT;
                self.busy_until[channel] = end;
                let mut level = true; // idle before the start bit
                for k in 0..n {
                    let bit = bits >> k & 1 == 1;
                    if bit != level {
                        self.queue(start + u64::from(k) * SAMPLES_PER_BIT, channel, bit);
                        level = bit;
                    }
                }
                if !level {
                    self.queue(end, channel, true);
                }
            }
            LineItem::Level { channel, high, .. } => {
                if channel < self.level.len() {
                    self.queue(at, channel, high);
                }
            }
        }
    }

    /// Release every edge; returns the sample at which the line is quiet again (the last
    /// edge, or the end of the last character).
    pub fn finish(&mut self, out: &mut impl FnMut(Edge)) -> u64 {
        self.release_before(u64::MAX, out);
        let busy = self.busy_until.iter().copied().max().unwrap_or(0);
        self.last.max(busy).max(self.floor)
    }

    fn queue(&mut self, sample: u64, channel: usize, high: bool) {
        self.pending
            .push(Reverse((sample, self.seq, channel, high)));
        self.seq += 1;
    }

    fn release_before(&mut self, sample: u64, out: &mut impl FnMut(Edge)) {
        while let Some(Reverse((s, _, channel, high))) = self.pending.peek().copied() {
            if s >= sample {
                break;
            }
            self.pending.pop();
            if self.level[channel] != high {
                self.level[channel] = high;
                self.last = s;
                out(Edge {
                    sample: s,
                    channel,
                    high,
                });
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn settings(parity: Parity) -> SerialSettings {
        SerialSettings::new(9600, 8, parity, 1).unwrap()
    }

    // The literals are grouped by field (stop, parity, data, start), not by nibble.
    #[allow(clippy::unusual_byte_groupings)]
    #[test]
    fn a_character_is_start_data_lsb_first_parity_stop() {
        // 'A' = 41H = 0100_0001: two ones, even parity bit 0.
        let (bits, n) = char_bits(&settings(Parity::Even), Ok(0x41)).unwrap();
        assert_eq!(n, 11);
        // bit0 start 0, data 1,0,0,0,0,0,1,0, parity 0, stop 1
        assert_eq!(bits, 0b1_0_01000001_0);
        let (bits, _) = char_bits(&settings(Parity::Odd), Ok(0x41)).unwrap();
        assert_eq!(bits, 0b1_1_01000001_0);
        let (bits, n) = char_bits(&settings(Parity::None), Ok(0xFF)).unwrap();
        assert_eq!((bits, n), (0b1_11111111_0, 10));
    }

    #[test]
    fn errors_are_drawn_as_the_receiver_saw_them() {
        let s = settings(Parity::Even);
        assert_eq!(char_bits(&s, Err(LineError::Break)), Some((0, 11)));
        assert_eq!(char_bits(&s, Err(LineError::Overrun)), None);
        // Parity: 00H needs parity 0 (even), drawn 1; stop bit high.
        assert_eq!(
            char_bits(&s, Err(LineError::Parity)),
            Some((1 << 9 | 1 << 10, 11))
        );
        // Framing: stop bit low.
        assert_eq!(char_bits(&s, Err(LineError::Framing)), Some((0, 11)));
    }

    fn edges(items: &[LineItem], channels: usize) -> (Vec<Edge>, u64) {
        let mut l = Levels::new(settings(Parity::Even), vec![true; channels]);
        let mut v = Vec::new();
        for &i in items {
            l.push(i, &mut |e| v.push(e));
        }
        let end = l.finish(&mut |e| v.push(e));
        (v, end)
    }

    #[test]
    fn edges_fall_on_bit_boundaries_at_sixteen_samples_per_bit() {
        // 1 ms at 153 600 Hz is sample 153 (153.6 rounded down), after the lead-in of two
        // 11-bit characters (352 samples).
        let (v, end) = edges(
            &[LineItem::Char {
                start: Instant::from_micros(1000),
                channel: 0,
                item: Ok(0x01),
            }],
            1,
        );
        let e = |sample, high| Edge {
            sample,
            channel: 0,
            high,
        };
        // start low at 153, data bit 0 = 1 high at 169, bits 1..7 low at 185, parity 1 at
        // 153 + 9·16, stop stays high.
        let l = 352;
        assert_eq!(
            v,
            vec![
                e(l + 153, false),
                e(l + 169, true),
                e(l + 185, false),
                e(l + 297, true)
            ]
        );
        assert_eq!(end, l + 153 + 11 * 16);
    }

    #[test]
    fn two_channels_interleave_in_sample_order_and_a_channel_waits_for_itself() {
        let c = |us, channel| LineItem::Char {
            start: Instant::from_micros(us),
            channel,
            item: Ok(0x00),
        };
        // Two characters of channel 0 given at the same instant: the second follows the first.
        let (v, _) = edges(&[c(0, 0), c(0, 0), c(100, 1)], 2);
        assert!(v.windows(2).all(|w| w[0].sample <= w[1].sample), "{v:?}");
        let ch0: Vec<u64> = v
            .iter()
            .filter(|e| e.channel == 0 && !e.high)
            .map(|e| e.sample)
            .collect();
        assert_eq!(ch0, vec![352, 352 + 176]);
        assert!(v.iter().any(|e| e.channel == 1));
    }

    #[test]
    fn a_level_item_sets_a_control_line() {
        let (v, _) = edges(
            &[LineItem::Level {
                at: Instant::from_micros(500),
                channel: 0,
                high: false,
            }],
            1,
        );
        assert_eq!(
            v,
            vec![Edge {
                sample: 352 + 76,
                channel: 0,
                high: false
            }]
        );
    }
}

//! Adaptive binary range coder (the LZMA construction: 11-bit probabilities, shift-5
//! adaptation, carry propagation through a cached byte) with two additions EZW needs:
//!
//! - **Minimal termination.** Each pass ends with [`Encoder::finish`], which emits only as
//!   many bytes as pin a value inside the final interval (usually 1–2), so flushing at every
//!   pass costs about a byte per pass. The decoder pads a segment with zero bytes.
//! - **Exact prefixes.** A decoder fed a truncated segment reports, through
//!   [`Decoder::reliable`], whether every byte it has consumed so far was real. A decision
//!   taken while that holds is the encoder's decision, so a cut anywhere in a pass decodes
//!   the symbols before the cut exactly and stops.

/// Probability of a 0 bit, in 1/2048ths.
pub type Prob = u16;

const PROB_BITS: u32 = 11;
const PROB_ONE: u32 = 1 << PROB_BITS;
/// Adaptation speed: larger is slower and steadier.
const MOVE_BITS: u32 = 5;
const TOP: u32 = 1 << 24;

/// A context's initial state: even odds.
pub const PROB_INIT: Prob = (PROB_ONE / 2) as Prob;

/// Range encoder over one segment.
pub struct Encoder {
    low: u64,
    range: u32,
    cache: u8,
    /// Bytes waiting for a possible carry: `cache` followed by `pending - 1` bytes of 0xFF.
    pending: u64,
    /// The first cached byte of a segment is always zero and is never written.
    started: bool,
    out: Vec<u8>,
    /// `out` up to its last non-zero byte: bytes in `out` are final (a carry only reaches
    /// the cached ones) and termination trims only trailing zeros, so the finished segment
    /// is at least this long.
    committed: usize,
}

impl Default for Encoder {
    fn default() -> Self {
        Self::new()
    }
}

impl Encoder {
    pub fn new() -> Self {
        Self {
            low: 0,
            range: u32::MAX,
            cache: 0,
            pending: 1,
            started: false,
            out: Vec::new(),
            committed: 0,
        }
    }

    /// A lower bound on the length [`Self::finish`] will return.
    pub fn committed(&self) -> usize {
        self.committed
    }

    /// Codes `bit` with the adaptive probability `p` and updates it.
    #[inline]
    pub fn encode(&mut self, p: &mut Prob, bit: bool) {
        let bound = (self.range >> PROB_BITS) * u32::from(*p);
        if bit {
            self.low += u64::from(bound);
            self.range -= bound;
            *p -= *p >> MOVE_BITS;
        } else {
            self.range = bound;
            *p += ((PROB_ONE - u32::from(*p)) >> MOVE_BITS) as Prob;
        }
        while self.range < TOP {
            self.range <<= 8;
            self.shift_low();
        }
    }

    /// Codes `bit` at fixed even odds without a probability (LZMA's direct bits, CABAC's
    /// bypass bins): for bits that are coin tosses, cheaper than a context and no less
    /// compact.
    #[inline]
    pub fn encode_bypass(&mut self, bit: bool) {
        self.range >>= 1;
        if bit {
            self.low += u64::from(self.range);
        }
        while self.range < TOP {
            self.range <<= 8;
            self.shift_low();
        }
    }

    fn shift_low(&mut self) {
        if self.low < 0xFF00_0000 || self.low >= 1 << 32 {
            let carry = (self.low >> 32) as u8;
            let mut byte = self.cache;
            loop {
                if self.started {
                    let b = byte.wrapping_add(carry);
                    self.out.push(b);
                    if b != 0 {
                        self.committed = self.out.len();
                    }
                }
                self.started = true;
                byte = 0xFF;
                self.pending -= 1;
                if self.pending == 0 {
                    break;
                }
            }
            self.cache = ((self.low >> 24) & 0xFF) as u8;
        }
        self.pending += 1;
        self.low = (self.low & 0x00FF_FFFF) << 8;
    }

    /// Terminates the segment with the fewest bytes that keep every decision decodable when
    /// the decoder pads with zeros.
    pub fn finish(mut self) -> Vec<u8> {
        // Round `low` up to a multiple of 2^(32 - 8n) that still lies below low + range, for the
        // smallest n: only the top n bytes of the window then need to be written.
        let hi = self.low + u64::from(self.range);
        let mut nbytes = 4;
        for n in 1..=4u32 {
            let mask = (1u64 << (32 - 8 * n)) - 1;
            let v = (self.low + mask) & !mask;
            if v < hi {
                self.low = v;
                nbytes = n;
                break;
            }
        }
        for _ in 0..=nbytes {
            self.shift_low();
        }
        // Trailing zero bytes are implied by the decoder's padding.
        while self.out.last() == Some(&0) {
            self.out.pop();
        }
        self.out
    }
}

/// Range decoder over one segment (or a truncated prefix of one).
pub struct Decoder<'a> {
    bytes: &'a [u8],
    /// Bytes taken into the window so far, padding included: past `bytes.len()` once a
    /// padding byte entered the window.
    pos: usize,
    range: u32,
    code: u32,
}

impl<'a> Decoder<'a> {
    pub fn new(bytes: &'a [u8]) -> Self {
        let mut code = 0;
        for i in 0..4 {
            code = (code << 8) | u32::from(bytes.get(i).copied().unwrap_or(0));
        }
        Self {
            bytes,
            pos: 4,
            range: u32::MAX,
            code,
        }
    }

    /// True while every byte in the window came from the input: the next decision is exact
    /// even if the segment was cut short.
    #[inline]
    pub fn reliable(&self) -> bool {
        self.pos <= self.bytes.len()
    }

    /// Decodes one decision. Branch-free in the decoded bit: refinement and sign bits are
    /// coin tosses, and a mispredicted branch costs more than computing both outcomes.
    #[inline]
    pub fn decode(&mut self, p: &mut Prob) -> bool {
        let pv = u32::from(*p);
        let bound = (self.range >> PROB_BITS) * pv;
        let bit = self.code >= bound;
        let mask = 0u32.wrapping_sub(u32::from(bit));
        self.code -= bound & mask;
        self.range = (bound & !mask) | (self.range.wrapping_sub(bound) & mask);
        let up = pv + ((PROB_ONE - pv) >> MOVE_BITS);
        let down = pv - (pv >> MOVE_BITS);
        *p = ((up & !mask) | (down & mask)) as Prob;
        self.normalize();
        bit
    }

    /// Shifts in the next byte when the range has fallen below 2^24. One byte always
    /// restores it: p stays within [31, 2017] of 2048, so a decision shrinks a range ≥ 2^24
    /// to no less than 2^17. Branch-free: whether a byte is due follows the coded bits and
    /// is as hard to predict.
    #[inline]
    fn normalize(&mut self) {
        let need = self.range < TOP;
        let shift = u32::from(need) * 8;
        let byte = self.bytes.get(self.pos).copied().unwrap_or(0);
        self.range <<= shift;
        let fresh = u32::from(byte) & 0u32.wrapping_sub(u32::from(need));
        self.code = (self.code << shift) | fresh;
        self.pos += usize::from(need);
        debug_assert!(self.range >= TOP);
    }

    /// Decodes a bit coded by [`Encoder::encode_bypass`].
    #[inline]
    pub fn decode_bypass(&mut self) -> bool {
        self.range >>= 1;
        let bit = self.code >= self.range;
        self.code -= self.range & 0u32.wrapping_sub(u32::from(bit));
        self.normalize();
        bit
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn encode_all(bits: &[(usize, bool)], nctx: usize) -> Vec<u8> {
        let mut ctx = vec![PROB_INIT; nctx];
        let mut enc = Encoder::new();
        for &(c, b) in bits {
            enc.encode(&mut ctx[c], b);
        }
        enc.finish()
    }

    proptest! {
        #[test]
        fn round_trip_any_bits(bits in prop::collection::vec((0usize..4, any::<bool>()), 0..3000)) {
            let bytes = encode_all(&bits, 4);
            let mut ctx = [PROB_INIT; 4];
            let mut dec = Decoder::new(&bytes);
            for &(c, b) in &bits {
                prop_assert_eq!(dec.decode(&mut ctx[c]), b);
            }
        }

        #[test]
        fn any_prefix_decodes_exactly_while_reliable(
            bits in prop::collection::vec((0usize..3, prop::bool::weighted(0.2)), 1..2000),
            cut in 0.0f64..=1.0,
        ) {
            let bytes = encode_all(&bits, 3);
            let cut = ((bytes.len() as f64) * cut) as usize;
            let mut ctx = [PROB_INIT; 3];
            let mut dec = Decoder::new(&bytes[..cut]);
            let mut decoded = 0;
            for &(c, b) in &bits {
                if !dec.reliable() {
                    break;
                }
                prop_assert_eq!(dec.decode(&mut ctx[c]), b);
                decoded += 1;
            }
            // A decision takes in at most one byte, and the window starts with four: every
            // byte of the prefix past the fourth carries at least one reliable decision.
            prop_assert!(
                decoded >= cut.saturating_sub(4).min(bits.len()),
                "{} of {} bits reliable from {} of {} bytes", decoded, bits.len(), cut, bytes.len()
            );
        }
    }

    #[test]
    fn termination_costs_about_a_byte() {
        // A skewed source compresses, and an empty segment is empty.
        assert!(encode_all(&[], 1).is_empty());
        let bits: Vec<_> = (0..10_000).map(|i| (0, i % 50 == 0)).collect();
        let n = encode_all(&bits, 1).len();
        assert!(n < 300, "10k bits at p=0.02 took {n} bytes");
    }
}

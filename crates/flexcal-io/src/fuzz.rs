//! Seeded mutations of text files, for the reader robustness tests of every
//! crate: bit flips, byte insertions and deletions, truncations, duplicated
//! and removed lines, extreme numbers, swapped bytes. Deterministic for a
//! seed (a xorshift generator, no dependency), so a failing case can be
//! replayed.
//!
//! ```
//! use flexcal_io::fuzz::TextMutator;
//! let mut mutator = TextMutator::new(7);
//! let a = mutator.mutate("x_mm,y_mm\n1,2\n");
//! assert_eq!(a, TextMutator::new(7).mutate("x_mm,y_mm\n1,2\n"));
//! ```

/// Produces mutants of a text, reproducibly for a seed.
#[derive(Debug, Clone)]
pub struct TextMutator {
    state: u64,
}

impl TextMutator {
    /// A mutator seeded with `seed` (any value; 0 is replaced by a constant).
    pub fn new(seed: u64) -> Self {
        Self {
            state: if seed == 0 {
                0x9E37_79B9_7F4A_7C15
            } else {
                seed
            },
        }
    }

    fn next(&mut self) -> u64 {
        // xorshift64* (Vigna 2016).
        self.state ^= self.state >> 12;
        self.state ^= self.state << 25;
        self.state ^= self.state >> 27;
        self.state.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    /// A uniform integer in `0..n` (`n > 0`).
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }

    /// One mutant of `text`: one to three mutations stacked.
    pub fn mutate(&mut self, text: &str) -> String {
        let mut bytes = text.as_bytes().to_vec();
        let rounds = 1 + self.below(3);
        for _ in 0..rounds {
            if bytes.is_empty() {
                break;
            }
            let at = self.below(bytes.len());
            match self.below(8) {
                0 => bytes[at] ^= 1 << self.below(8),
                1 => bytes.truncate(at),
                2 => {
                    let pool = b"0123456789-.e,;<>/=\"{}[]( )*\n#";
                    bytes.insert(at, pool[self.below(pool.len())]);
                }
                3 => {
                    bytes.remove(at);
                }
                4 | 5 => {
                    let text = String::from_utf8_lossy(&bytes).into_owned();
                    let mut lines: Vec<&str> = text.lines().collect();
                    if lines.is_empty() {
                        continue;
                    }
                    let k = self.below(lines.len());
                    if self.below(2) == 0 {
                        lines.insert(k, lines[k]);
                    } else {
                        lines.remove(k);
                    }
                    bytes = lines.join("\n").into_bytes();
                }
                6 => {
                    let extremes: [&[u8]; 7] = [
                        b"1e308",
                        b"-0",
                        b"nan",
                        b"inf",
                        b"1e-320",
                        b"99999999999",
                        b"-1",
                    ];
                    let e = extremes[self.below(extremes.len())];
                    let end = (at + 1).min(bytes.len());
                    bytes.splice(at..end, e.iter().copied());
                }
                _ => {
                    let other = self.below(bytes.len());
                    bytes.swap(at, other);
                }
            }
        }
        String::from_utf8_lossy(&bytes).into_owned()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mutants_differ_and_replay() {
        let text = "a,b\n1,2\n3,4\n";
        let mut m = TextMutator::new(1);
        let mutants: Vec<String> = (0..100).map(|_| m.mutate(text)).collect();
        assert!(mutants.iter().filter(|s| s.as_str() != text).count() > 90);
        let mut again = TextMutator::new(1);
        assert!(mutants.iter().all(|s| *s == again.mutate(text)));
    }
}

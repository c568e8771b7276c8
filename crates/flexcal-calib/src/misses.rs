//! Which misses of a validation's 95 % bounds leaving the training ranges
//! can explain ([`MissesByRange`]).
//!
//! A measured pose whose error exceeds its predicted bound is a miss. Where
//! the pose lies outside the identification poses' range of some actuated
//! coordinate ([`crate::PoseAccuracy::outside_training_range`]), the
//! bound assumed that the model holds beyond the data, and the miss may be
//! the model's error growing there: the miss is *explained* by leaving
//! those ranges. A miss inside every range is not: there the bound itself
//! is too small (a noise stated below what the model leaves, effects
//! another day adds). Per coordinate, the misses among the poses outside
//! its range against the poses outside it say whether leaving it matters:
//! when nearly every pose is outside (a validation set that extrapolates
//! everywhere) and the misses inside are as frequent, leaving the range
//! explains nothing, however many misses it counts.

use serde::{Deserialize, Serialize};

use crate::accuracy::AccuracyMap;

/// Measured entries and the misses among them.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Misses {
    /// Number of measured entries (poses, or observations of a target).
    pub entries: usize,
    /// Entries whose error exceeds their 95 % bound.
    pub misses: usize,
}

impl Misses {
    /// Share of the entries that miss (0 without entries).
    pub fn rate(&self) -> f64 {
        self.misses as f64 / self.entries.max(1) as f64
    }

    fn add(&mut self, missed: bool) {
        self.entries += 1;
        self.misses += usize::from(missed);
    }
}

/// The entries outside one coordinate's training range.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CoordinateMisses {
    /// The actuated coordinate's name.
    pub coordinate: String,
    /// Entries outside its training range, and the misses among them.
    pub outside: Misses,
    /// Entries inside its training range (whatever the other coordinates),
    /// and the misses among them: the rate to compare the outside's with.
    pub inside: Misses,
    /// Misses outside this coordinate's range and inside every other's:
    /// those that leaving this range alone explains.
    pub misses_outside_this_alone: usize,
}

/// A validation's misses sorted by the training ranges (module docs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MissesByRange {
    /// Every measured entry.
    pub all: Misses,
    /// Entries inside every training range: their misses are not explained
    /// by leaving a range.
    pub inside: Misses,
    /// Per coordinate that some entry leaves, the most misses first.
    pub coordinates: Vec<CoordinateMisses>,
}

impl MissesByRange {
    /// Misses outside at least one training range: those leaving a range
    /// may explain.
    pub fn explained(&self) -> usize {
        self.all.misses - self.inside.misses
    }

    /// One line for reports: the misses, how many leaving a range may
    /// explain and by which coordinates, and how many it does not.
    pub fn summary(&self) -> String {
        let per_coordinate: Vec<String> = self
            .coordinates
            .iter()
            .map(|c| {
                format!(
                    "{} {} of {} outside ({:.0} %; {:.0} % of the {} inside its range; {} outside it alone)",
                    c.coordinate,
                    c.outside.misses,
                    c.outside.entries,
                    100.0 * c.outside.rate(),
                    100.0 * c.inside.rate(),
                    c.inside.entries,
                    c.misses_outside_this_alone
                )
            })
            .collect();
        format!(
            "{} misses of {} entries ({:.1} %); {} outside a training range{}{}; {} inside every range, not explained (of {} entries inside, {:.1} %)",
            self.all.misses,
            self.all.entries,
            100.0 * self.all.rate(),
            self.explained(),
            if per_coordinate.is_empty() { "" } else { ": " },
            per_coordinate.join(", "),
            self.inside.misses,
            self.inside.entries,
            100.0 * self.inside.rate()
        )
    }
}

impl AccuracyMap {
    /// The misses of the measured entries sorted by the training ranges
    /// they leave (module docs); `None` for a map without measured errors
    /// (a grid, a plan).
    pub fn misses_by_range(&self) -> Option<MissesByRange> {
        let mut all = Misses::default();
        let mut inside = Misses::default();
        let mut coordinates: Vec<CoordinateMisses> = Vec::new();
        for p in &self.poses {
            let error = p.actual_error_mm?;
            let missed = error > p.bound_95_mm;
            all.add(missed);
            if p.outside_training_range.is_empty() {
                inside.add(missed);
            }
            for name in &p.outside_training_range {
                let k = match coordinates.iter().position(|c| &c.coordinate == name) {
                    Some(k) => k,
                    None => {
                        coordinates.push(CoordinateMisses {
                            coordinate: name.clone(),
                            outside: Misses::default(),
                            inside: Misses::default(),
                            misses_outside_this_alone: 0,
                        });
                        coordinates.len() - 1
                    }
                };
                coordinates[k].outside.add(missed);
                if missed && p.outside_training_range.len() == 1 {
                    coordinates[k].misses_outside_this_alone += 1;
                }
            }
        }
        for c in &mut coordinates {
            c.inside = Misses {
                entries: all.entries - c.outside.entries,
                misses: all.misses - c.outside.misses,
            };
        }
        coordinates.sort_by(|a, b| {
            b.outside
                .misses
                .cmp(&a.outside.misses)
                .then_with(|| a.coordinate.cmp(&b.coordinate))
        });
        Some(MissesByRange {
            all,
            inside,
            coordinates,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accuracy::PoseAccuracy;
    use rand::{Rng, SeedableRng};

    fn entry(error: Option<f64>, bound: f64, outside: &[&str]) -> PoseAccuracy {
        PoseAccuracy {
            pose: "p".into(),
            target: None,
            q: vec![0.0; 3],
            model_uncertainty_mm: 0.0,
            bound_95_mm: bound,
            actual_error_mm: error,
            position_mm: [0.0; 3],
            parts: Default::default(),
            outside_training_range: outside.iter().map(|s| s.to_string()).collect(),
        }
    }

    fn map(poses: Vec<PoseAccuracy>) -> AccuracyMap {
        AccuracyMap {
            poses,
            residual_scatter_mm: 0.01,
            inflation: 1.0,
            coverage: None,
            mean_bound_95_mm: 0.0,
            extrapolated_poses: 0,
            extrapolation: None,
        }
    }

    #[test]
    fn a_grid_without_measured_errors_has_no_misses() {
        assert_eq!(map(vec![entry(None, 1.0, &[])]).misses_by_range(), None);
    }

    #[test]
    fn misses_are_counted_per_coordinate_and_inside() {
        let m = map(vec![
            entry(Some(2.0), 1.0, &["theta1"]),           // miss, theta1 alone
            entry(Some(2.0), 1.0, &["theta1", "theta2"]), // miss, both
            entry(Some(0.5), 1.0, &["theta2"]),           // within
            entry(Some(2.0), 1.0, &[]),                   // miss inside
            entry(Some(0.5), 1.0, &[]),                   // within inside
        ])
        .misses_by_range()
        .unwrap();
        assert_eq!(
            m.all,
            Misses {
                entries: 5,
                misses: 3
            }
        );
        assert_eq!(
            m.inside,
            Misses {
                entries: 2,
                misses: 1
            }
        );
        assert_eq!(m.explained(), 2);
        let theta1 = &m.coordinates[0];
        assert_eq!(theta1.coordinate, "theta1");
        assert_eq!(
            theta1.outside,
            Misses {
                entries: 2,
                misses: 2
            }
        );
        assert_eq!(theta1.misses_outside_this_alone, 1);
        assert_eq!(
            theta1.inside,
            Misses {
                entries: 3,
                misses: 1
            }
        );
        let theta2 = &m.coordinates[1];
        assert_eq!(
            theta2.outside,
            Misses {
                entries: 2,
                misses: 1
            }
        );
        assert_eq!(theta2.misses_outside_this_alone, 0);
        let line = m.summary();
        assert!(
            line.starts_with("3 misses of 5 entries (60.0 %); 2 outside"),
            "{line}"
        );
        assert!(
            line.contains(
                "theta1 2 of 2 outside (100 %; 33 % of the 3 inside its range; 1 outside it alone)"
            ),
            "{line}"
        );
        assert!(
            line.contains("1 inside every range, not explained (of 2 entries inside, 50.0 %)"),
            "{line}"
        );
    }

    /// Invariants on random maps: the misses inside and the explained ones
    /// add up to all misses; a coordinate's misses never exceed the
    /// explained ones nor its entries; the misses agree with the coverage
    /// computed independently.
    #[test]
    fn counts_add_up_on_random_maps() {
        let names = ["theta1", "theta2", "theta3", "theta4"];
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        for _ in 0..50 {
            let n = rng.random_range(1..40);
            let poses: Vec<PoseAccuracy> = (0..n)
                .map(|_| {
                    let outside: Vec<&str> = names
                        .iter()
                        .copied()
                        .filter(|_| rng.random_bool(0.3))
                        .collect();
                    entry(Some(rng.random_range(0.0..2.0)), 1.0, &outside)
                })
                .collect();
            let within = poses
                .iter()
                .filter(|p| p.actual_error_mm.unwrap() <= p.bound_95_mm)
                .count();
            let m = map(poses).misses_by_range().unwrap();
            assert_eq!(m.all.entries, n);
            assert_eq!(m.all.misses, n - within);
            assert_eq!(m.inside.misses + m.explained(), m.all.misses);
            for c in &m.coordinates {
                assert!(c.outside.misses <= m.explained());
                assert_eq!(c.outside.entries + c.inside.entries, n);
                assert!(c.inside.misses >= m.inside.misses);
                assert!(c.outside.misses <= c.outside.entries);
                assert!(c.misses_outside_this_alone <= c.outside.misses);
            }
            assert!(
                m.coordinates
                    .windows(2)
                    .all(|w| w[0].outside.misses >= w[1].outside.misses)
            );
        }
    }
}

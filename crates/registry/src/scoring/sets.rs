//! Scores of a visible set against a ground truth: precision, recall, F1, Jaccard.
//!
//! Conventions for empty sets: precision is 1 when nothing is predicted, recall is 1 when
//! nothing is truly visible, F1 and Jaccard are 1 when both sets are empty.

/// Confusion counts and the scores derived from them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Score {
    /// Predicted and truly visible.
    pub true_positives: usize,
    /// Predicted but not truly visible.
    pub false_positives: usize,
    /// Truly visible but not predicted.
    pub false_negatives: usize,
}

impl Score {
    /// Scores `predicted` (indices, ascending, no repeats) against `truth` (one flag per point).
    pub fn of(predicted: &[u32], truth: &[bool]) -> Self {
        let true_positives = predicted.iter().filter(|&&i| truth[i as usize]).count();
        let n_true = truth.iter().filter(|&&t| t).count();
        Self {
            true_positives,
            false_positives: predicted.len() - true_positives,
            false_negatives: n_true - true_positives,
        }
    }

    /// Scores `predicted` against `truth`, leaving out the points flagged in `off_surface`
    /// (a real scan's points too far from the mesh for the mesh to say whether they are seen):
    /// they count as neither true nor false.
    pub fn of_on_surface(predicted: &[u32], truth: &[bool], off_surface: Option<&[bool]>) -> Self {
        let Some(off) = off_surface else {
            return Self::of(predicted, truth);
        };
        let on = |i: usize| !off[i];
        let true_positives = predicted
            .iter()
            .filter(|&&i| on(i as usize) && truth[i as usize])
            .count();
        let predicted_on = predicted.iter().filter(|&&i| on(i as usize)).count();
        let n_true = (0..truth.len()).filter(|&i| on(i) && truth[i]).count();
        Self {
            true_positives,
            false_positives: predicted_on - true_positives,
            false_negatives: n_true - true_positives,
        }
    }

    /// Scores two index sets against each other (both ascending, no repeats).
    pub fn of_sets(predicted: &[u32], truth: &[u32]) -> Self {
        let (mut i, mut j, mut tp) = (0, 0, 0);
        while i < predicted.len() && j < truth.len() {
            match predicted[i].cmp(&truth[j]) {
                std::cmp::Ordering::Less => i += 1,
                std::cmp::Ordering::Greater => j += 1,
                std::cmp::Ordering::Equal => {
                    tp += 1;
                    i += 1;
                    j += 1;
                }
            }
        }
        Self {
            true_positives: tp,
            false_positives: predicted.len() - tp,
            false_negatives: truth.len() - tp,
        }
    }

    /// TP / (TP + FP).
    pub fn precision(&self) -> f64 {
        ratio(
            self.true_positives,
            self.true_positives + self.false_positives,
        )
    }

    /// TP / (TP + FN).
    pub fn recall(&self) -> f64 {
        ratio(
            self.true_positives,
            self.true_positives + self.false_negatives,
        )
    }

    /// 2TP / (2TP + FP + FN).
    pub fn f1(&self) -> f64 {
        ratio(
            2 * self.true_positives,
            2 * self.true_positives + self.false_positives + self.false_negatives,
        )
    }

    /// TP / (TP + FP + FN).
    pub fn jaccard(&self) -> f64 {
        ratio(
            self.true_positives,
            self.true_positives + self.false_positives + self.false_negatives,
        )
    }
}

fn ratio(num: usize, den: usize) -> f64 {
    if den == 0 {
        1.0
    } else {
        num as f64 / den as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_and_scores() {
        let truth = [true, true, false, false, true];
        let s = Score::of(&[0, 2, 4], &truth);
        assert_eq!(
            (s.true_positives, s.false_positives, s.false_negatives),
            (2, 1, 1)
        );
        assert!((s.precision() - 2.0 / 3.0).abs() < 1e-12);
        assert!((s.recall() - 2.0 / 3.0).abs() < 1e-12);
        assert!((s.f1() - 2.0 / 3.0).abs() < 1e-12);
        assert!((s.jaccard() - 0.5).abs() < 1e-12);
        assert_eq!(Score::of_sets(&[0, 2, 4], &[0, 1, 4]), s);
    }

    #[test]
    fn off_surface_points_count_as_neither() {
        let truth = [true, true, false, false, true];
        let off = [false, true, false, true, false];
        // Point 1 (truly visible, missed) and 3 (hidden, predicted) are off the surface.
        let s = Score::of_on_surface(&[0, 3, 4], &truth, Some(&off));
        assert_eq!(
            (s.true_positives, s.false_positives, s.false_negatives),
            (2, 0, 0)
        );
        assert_eq!(
            Score::of_on_surface(&[0, 3], &truth, None),
            Score::of(&[0, 3], &truth)
        );
    }

    #[test]
    fn empty_sets() {
        let s = Score::of(&[], &[false, false]);
        assert_eq!(
            (s.precision(), s.recall(), s.f1(), s.jaccard()),
            (1.0, 1.0, 1.0, 1.0)
        );
        let s = Score::of(&[], &[true]);
        assert_eq!((s.recall(), s.f1()), (0.0, 0.0));
    }
}

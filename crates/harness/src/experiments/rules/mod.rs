//! The rules every comparison in the reports follows, in one place, below every experiment
//! (nothing here imports an experiment): the verdict over a condition's cells ([`verdict`]:
//! the same cells for every method, one statistic, identical answers named, a practical
//! margin), wrong answers ([`wrong`]: a failed exactness claim is never ranked), time ratios
//! against the peers ([`ratio`]: one pairing rule) and the LOD rate-distortion curves
//! ([`curve`]: budgets read in log points, BD-PSNR). The findings and the experiments'
//! summaries both apply them; `docs/verdicts.md` states them in plain words and
//! `scripts/audit_findings.py` recomputes the findings by them.

pub mod curve;
pub mod ratio;
pub mod verdict;
pub mod wrong;

//! `--shard K/N`: which part of an experiment's cells one process runs. The experiments deal
//! their cells by it ([`crate::experiments::Context::owns`]), the run metadata records it and
//! `pointsight merge` checks it; it depends on nothing of the harness.

/// `--shard K/N`: the K-th of N parts (1-based) of an experiment's cells.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Shard {
    /// This part, 1..=n.
    pub k: usize,
    /// Number of parts.
    pub n: usize,
}

impl Shard {
    /// True when cell number `cell` (0-based) belongs to this part.
    pub fn owns(&self, cell: usize) -> bool {
        cell % self.n == self.k - 1
    }
}

impl std::str::FromStr for Shard {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let (k, n) = s
            .split_once('/')
            .ok_or_else(|| format!("--shard expects K/N (for example 2/8), got {s:?}"))?;
        let (k, n): (usize, usize) = (
            k.trim()
                .parse()
                .map_err(|_| format!("--shard {s}: K is not a whole number"))?,
            n.trim()
                .parse()
                .map_err(|_| format!("--shard {s}: N is not a whole number"))?,
        );
        if n == 0 || k == 0 || k > n {
            return Err(format!("--shard {s}: expects 1 <= K <= N"));
        }
        Ok(Self { k, n })
    }
}

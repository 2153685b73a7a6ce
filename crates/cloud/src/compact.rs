//! Joining the parts of a selection made in parallel.
//!
//! A parallel filter (the SPT cut, the SRN selection) gives each chunk of its input its own
//! run of slots in one output vector, one slot per input item; a chunk writes the indices it
//! keeps at the front of its run. [`join_parts`] then moves the kept prefixes together, in
//! order, so that the vector holds the whole selection and nothing else.

/// Moves together the kept prefixes of consecutive parts of `out[base..]`, given per part
/// `(kept, slots)` (the last part's slots may be anything), and truncates `out` after them.
/// Returns the new length of `out`.
pub fn join_parts(
    out: &mut Vec<u32>,
    base: usize,
    parts: impl IntoIterator<Item = (usize, usize)>,
) -> usize {
    let (mut len, mut at) = (base, base);
    for (kept, slots) in parts {
        out.copy_within(at..at + kept, len);
        len += kept;
        at += slots;
    }
    out.truncate(len);
    len
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kept_prefixes_are_moved_together_in_order() {
        // A prefix that stays, then parts of 3 slots (2 kept), 2 (0 kept), 3 (3 kept), 4 (1).
        let mut out = vec![9, 9, 0, 1, 77, 77, 77, 5, 6, 7, 8, 77, 77, 77];
        let len = join_parts(&mut out, 2, [(2, 3), (0, 2), (3, 3), (1, 4)]);
        assert_eq!(len, 8);
        assert_eq!(out, vec![9, 9, 0, 1, 5, 6, 7, 8]);
        let mut empty = vec![4];
        assert_eq!(join_parts(&mut empty, 1, []), 1);
        assert_eq!(empty, vec![4]);
    }
}

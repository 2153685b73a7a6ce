//! Block checksums for the built LOD files (QSplat's and SPT's): a CRC-32 (IEEE 802.3, the
//! `crc32fast` crate) of each fixed-size block of a section, so that a reader that reads a
//! file a block at a time can check each block it reads, and one CRC-32 over the rest (the
//! header and the table of block checksums) so that nothing in the file goes unchecked.
//!
//! A value that stays finite and in range after a flipped byte cannot be caught by checking
//! values; a checksum catches every single-byte change (CRC-32 detects every burst of up to 32
//! bits).
//!
//! The writers compute the same sums whether they hold the file in memory ([`block_sums`]) or
//! stream it ([`BlockSums`], [`Summed`]), so both builds write the same bytes.

use std::io::{self, Write};

/// The CRC-32 of `data`.
pub fn crc32(data: &[u8]) -> u32 {
    crc32fast::hash(data)
}

/// The CRC-32 of each `block`-byte piece of `data` (the last may be shorter; none for empty
/// data).
pub fn block_sums(data: &[u8], block: usize) -> Vec<u32> {
    data.chunks(block.max(1)).map(crc32).collect()
}

/// Blocks of `block` bytes in a section of `len` bytes.
pub fn block_count(len: u64, block: u64) -> u64 {
    len.div_ceil(block.max(1))
}

/// The CRC-32 of each `block`-byte piece of a stream, fed in pieces of any size.
#[derive(Debug, Clone)]
pub struct BlockSums {
    block: usize,
    filled: usize,
    hasher: crc32fast::Hasher,
    sums: Vec<u32>,
}

impl BlockSums {
    /// Sums of `block`-byte blocks.
    pub fn new(block: usize) -> Self {
        Self {
            block: block.max(1),
            filled: 0,
            hasher: crc32fast::Hasher::new(),
            sums: Vec::new(),
        }
    }

    /// Feeds `data`.
    pub fn update(&mut self, mut data: &[u8]) {
        while !data.is_empty() {
            let take = (self.block - self.filled).min(data.len());
            self.hasher.update(&data[..take]);
            self.filled += take;
            data = &data[take..];
            if self.filled == self.block {
                let h = std::mem::take(&mut self.hasher);
                self.sums.push(h.finalize());
                self.filled = 0;
            }
        }
    }

    /// The sums, the last block's included when it is short.
    pub fn finish(mut self) -> Vec<u32> {
        if self.filled > 0 {
            self.sums.push(self.hasher.finalize());
        }
        self.sums
    }
}

/// A writer that sums what passes through it in blocks.
#[derive(Debug)]
pub struct Summed<W> {
    inner: W,
    sums: BlockSums,
}

impl<W: Write> Summed<W> {
    /// Sums what is written to `inner` in `block`-byte blocks.
    pub fn new(inner: W, block: usize) -> Self {
        Self {
            inner,
            sums: BlockSums::new(block),
        }
    }

    /// The writer and the sums.
    pub fn finish(self) -> (W, Vec<u32>) {
        (self.inner, self.sums.finish())
    }
}

impl<W: Write> Write for Summed<W> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.sums.update(&buf[..n]);
        Ok(n)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.inner.flush()
    }
}

/// The trailer of a file: the block sums (u32 little-endian each, in order), then the CRC-32
/// of `head` (the bytes outside every block, in file order) followed by the table's bytes.
pub fn trailer(head: &[&[u8]], sums: &[u32]) -> Vec<u8> {
    let mut b = Vec::with_capacity(4 * sums.len() + 4);
    for s in sums {
        b.extend_from_slice(&s.to_le_bytes());
    }
    let mut h = crc32fast::Hasher::new();
    for part in head {
        h.update(part);
    }
    h.update(&b);
    let c = h.finalize();
    b.extend_from_slice(&c.to_le_bytes());
    b
}

/// Checks a trailer read from a file (`table` is its bytes, the sums then the head's sum)
/// against `head`: the block sums when the head's sum matches, else `None`.
pub fn check_trailer(head: &[&[u8]], table: &[u8]) -> Option<Vec<u32>> {
    let (sums, last) = table.split_at_checked(table.len().checked_sub(4)?)?;
    if sums.len() % 4 != 0 {
        return None;
    }
    let mut h = crc32fast::Hasher::new();
    for part in head {
        h.update(part);
    }
    h.update(sums);
    let want = u32::from_le_bytes(last.try_into().ok()?);
    (h.finalize() == want).then(|| {
        sums.chunks_exact(4)
            .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect()
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streamed_sums_equal_the_sums_of_the_whole() {
        let data: Vec<u8> = (0..10_000u32).map(|i| (i * 7 + i / 13) as u8).collect();
        for block in [1, 7, 64, 4096, 20_000] {
            let want = block_sums(&data, block);
            assert_eq!(
                want.len() as u64,
                block_count(data.len() as u64, block as u64)
            );
            let mut s = BlockSums::new(block);
            for piece in data.chunks(333) {
                s.update(piece);
            }
            assert_eq!(s.finish(), want, "{block}");
            let mut w = Summed::new(Vec::new(), block);
            for piece in data.chunks(1000) {
                w.write_all(piece).unwrap();
            }
            let (bytes, sums) = w.finish();
            assert_eq!((bytes, sums), (data.clone(), want));
        }
        // The standard check value of CRC-32.
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
    }

    #[test]
    fn a_trailer_checks_its_head_and_table() {
        let head = b"header bytes".as_slice();
        let t = trailer(&[head], &[1, 2, 3]);
        assert_eq!(check_trailer(&[head], &t), Some(vec![1, 2, 3]));
        for i in 0..t.len() {
            let mut d = t.clone();
            d[i] ^= 0x10;
            assert_eq!(check_trailer(&[head], &d), None, "byte {i}");
        }
        assert_eq!(check_trailer(&[b"header bytez"], &t), None);
        assert_eq!(check_trailer(&[head], &t[..3]), None);
    }
}

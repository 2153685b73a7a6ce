//! The recursive rendering of seed 002 §5.3.3: depth first from the root, a node is refined
//! while its image-space error is at least ε and it is not a leaf, drawn otherwise. It uses the
//! same test ([`crate::list::refined`]) on the same quantised values as the sequential cut, of
//! which it is the reference.

use cloud::glam::Vec3;

use crate::hierarchy::Hierarchy;
use crate::list::{Quantized, refined};

/// The nodes drawn, in depth-first order.
pub fn cut(h: &Hierarchy, q: &Quantized, eye: Vec3, eps2: f32) -> Vec<u32> {
    let mut out = Vec::new();
    let mut stack = vec![h.root() as u32];
    while let Some(n) = stack.pop() {
        let i = n as usize;
        if !h.nodes[i].children.is_empty() && refined(&q.boxes[i], q.e2[i], eye, eps2) {
            stack.extend(h.nodes[i].children.iter().rev());
        } else {
            out.push(n);
        }
    }
    out
}

//! A compact copy of parry's BVH over a mesh's triangles, for the fingers' ray casts.
//!
//! # Why
//! A finger's cast walks the mesh's BVH from the root to the triangles near its way; on a large
//! mesh the nodes it meets are mostly out of the cache. parry's tree is binary, each node's box
//! in `f64` (a pair of siblings 112 bytes): about 21 pairs and 43 box tests a ray on the
//! benchmark's 100,000-triangle torus (`docs/performance.md`).
//!
//! # The copy
//! The same tree with two levels in one node: each node holds the (up to) four grandchildren of a
//! node of parry's tree (a child that is a leaf stays as it is). A node is 112 bytes (two cache
//! lines, 64-byte aligned): the four boxes side by side per axis in `f32`, each bound rounded
//! outward ([`down`], [`up`]) so that the box contains parry's, and the four children (a node's
//! index, or a triangle's with [`LEAF`] set). About 10 nodes and 2 triangle tests a ray on the
//! torus. The triangles are the mesh's own (parry's `f64` corners).
//!
//! # Exactness
//! A box test is monotone in the box's bounds (the slab times `(bound − o)/d` are rounded
//! subtractions and products, each monotone), so a box containing parry's box is entered no later
//! and left no earlier. The triangle test is parry's own on the same corners, and the first hit is
//! the least time of impact over the triangles whatever the order they are tried in: the same
//! time, bit for bit, as parry's search. Only where two triangles give the very same time (a ray
//! through the edge or vertex they share) may the other one be named, at the same point (whose
//! normal is then the edge's or vertex's pseudo-normal, or, between coplanar faces, the face
//! normal of the one named). The unit tests also found rays (about 1 in 450 of theirs, mostly
//! through a triangle's edge or corner, some not) whose first hit parry's search of its own tree
//! misses, taking a later triangle: this walk finds the first, which the test checks against plain
//! ray-triangle tests over all the triangles.
//!
//! # Tried and left out
//! One walk for both fingers (they move on one line in opposite directions, so one walk can keep
//! the first hit from each end): on a binary copy of the tree it opened 6 % fewer nodes than the
//! two walks but tested each box against both rays, and a pose took 3.25 µs against 2.3 µs for
//! two walks (and 1.85 µs with parry's). Taking the two fingers' walks a node at a time in turn,
//! so that their waits on memory overlap, gave nothing measurable (1.78 against 1.72 µs a pose).

use parry3d_f64::math::Vector;
use parry3d_f64::partitioning::{Bvh, BvhNode, BvhNodeIndex, TraversalAction};
use parry3d_f64::query::{Ray, RayCast};
use parry3d_f64::shape::TriMesh;

/// A child's index with this bit set is a triangle's (the mesh's index), else a node's.
const LEAF: u32 = 1 << 31;

/// The child of an empty slot.
const NONE: u32 = u32::MAX;

/// A node of four children: their boxes, rounded outward to `f32`, side by side per axis (an
/// empty slot's box has `mins > maxs`, which no ray enters, and its child is [`NONE`]), and each
/// child's node or triangle ([`LEAF`]). 112 bytes, two cache lines.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
struct Quad {
    mins: [[f32; 4]; 3],
    maxs: [[f32; 4]; 3],
    child: [u32; 4],
}

impl Quad {
    const EMPTY: Quad = Quad {
        mins: [[f32::INFINITY; 4]; 3],
        maxs: [[f32::NEG_INFINITY; 4]; 3],
        child: [NONE; 4],
    };
}

/// The largest `f32` at most `x`.
fn down(x: f64) -> f32 {
    let y = x as f32;
    if f64::from(y) > x {
        y.next_down()
    } else {
        y
    }
}

/// The least `f32` at least `x`.
fn up(x: f64) -> f32 {
    let y = x as f32;
    if f64::from(y) < x {
        y.next_up()
    } else {
        y
    }
}

/// The compact tree: `quads[0]` is the root.
#[derive(Debug, Clone)]
pub(crate) struct CompactBvh {
    quads: Vec<Quad>,
}

/// The two children of the node at `index` in parry's tree (none for a leaf), as parry's own
/// traversal reports them.
fn children(bvh: &Bvh, index: BvhNodeIndex) -> Vec<(BvhNodeIndex, BvhNode)> {
    let mut found = Vec::with_capacity(2);
    let mut first = true;
    bvh.traverse_indexed(Some(index), |node, i| {
        if first {
            first = false;
            TraversalAction::Continue
        } else {
            found.push((i, *node));
            TraversalAction::Prune
        }
    });
    found
}

/// The children of a node of four: the two children of a node of parry's tree, each that is not
/// a leaf replaced by its own two children.
fn grandchildren(bvh: &Bvh, nodes: Vec<(BvhNodeIndex, BvhNode)>) -> Vec<(BvhNodeIndex, BvhNode)> {
    nodes
        .into_iter()
        .flat_map(|(index, node)| {
            if node.is_leaf() {
                vec![(index, node)]
            } else {
                children(bvh, index)
            }
        })
        .collect()
}

impl CompactBvh {
    /// The copy of a mesh's BVH (see the module's documentation).
    pub(crate) fn new(trimesh: &TriMesh) -> Self {
        let bvh = trimesh.bvh();
        let mut roots = Vec::with_capacity(2);
        bvh.traverse_indexed(None, |node, i| {
            roots.push((i, *node));
            TraversalAction::Prune
        });
        let mut quads = vec![Quad::EMPTY];
        let mut stack = vec![(0usize, grandchildren(bvh, roots))];
        while let Some((slot, kids)) = stack.pop() {
            for (k, (index, node)) in kids.into_iter().enumerate().take(4) {
                let (mins, maxs) = (node.mins(), node.maxs());
                for (axis, (lo, hi)) in [(mins.x, maxs.x), (mins.y, maxs.y), (mins.z, maxs.z)]
                    .into_iter()
                    .enumerate()
                {
                    quads[slot].mins[axis][k] = down(lo);
                    quads[slot].maxs[axis][k] = up(hi);
                }
                quads[slot].child[k] = match node.leaf_data() {
                    Some(id) => id | LEAF,
                    None => {
                        let below = quads.len();
                        quads.push(Quad::EMPTY);
                        stack.push((below, grandchildren(bvh, children(bvh, index))));
                        below as u32
                    }
                };
            }
        }
        CompactBvh { quads }
    }

    /// This tree for its mesh scaled uniformly by `factor` (`> 0`, the mesh's vertices each
    /// multiplied by it): each bound multiplied by it and rounded outward to `f32` again, in one
    /// pass without building anything. Each bound held its subtree's corners (at most the least
    /// coordinate, at least the greatest); a product by a positive factor is monotone, exact and
    /// rounded alike, so the scaled bound holds the scaled corners, and a first hit is found as
    /// in any tree whose boxes hold their triangles (the module's "Exactness"). An empty slot
    /// stays empty (infinite bounds stay infinite).
    pub(crate) fn scaled(&self, factor: f64) -> Self {
        let scale = |bounds: [[f32; 4]; 3], round: fn(f64) -> f32| {
            bounds.map(|axis| axis.map(|b| round(f64::from(b) * factor)))
        };
        let quads = self
            .quads
            .iter()
            .map(|q| Quad {
                mins: scale(q.mins, down),
                maxs: scale(q.maxs, up),
                child: q.child,
            })
            .collect();
        CompactBvh { quads }
    }

    /// What it holds, bytes.
    pub(crate) fn bytes(&self) -> usize {
        std::mem::size_of_val(&self.quads[..])
    }

    /// The first triangle a ray meets within `max` (the mesh's index), and when: a best-first
    /// walk as parry's `Bvh::find_best` (the nearest child first, a node kept while its box's
    /// entry is before the best hit so far), a node put aside dropped unopened when a hit found
    /// meanwhile comes before its box.
    pub(crate) fn first_hit(&self, trimesh: &TriMesh, ray: &Ray, max: f64) -> Option<(u32, f64)> {
        let mut walk = Walk::new(ray, max);
        while walk.step(self, trimesh) {}
        walk.hit()
    }
}

/// One ray's walk of the tree: the node it is at, the nodes put aside, the best hit so far.
struct Walk<'r> {
    ray: &'r Ray,
    slabs: Slabs,
    best: f64,
    hit: Option<u32>,
    current: Option<u32>,
    stack: Stack<(u32, f64)>,
}

impl<'r> Walk<'r> {
    fn new(ray: &'r Ray, max: f64) -> Self {
        Walk {
            ray,
            slabs: Slabs::new(ray),
            best: max,
            hit: None,
            current: Some(0),
            stack: Stack::new((0, 0.0)),
        }
    }

    /// Opens the current node (its triangles tried, its nodes put aside, the nearest kept as the
    /// next), then goes to the next: whether there is one.
    #[inline(always)]
    fn step(&mut self, tree: &CompactBvh, trimesh: &TriMesh) -> bool {
        let Some(current) = self.current else {
            return false;
        };
        let quad = &tree.quads[current as usize];
        let entries = self.slabs.entries(quad, self.best);
        let mut next = None;
        let mut later = [(0u32, 0.0f64); 3];
        let mut count = 0;
        for k in ascending(&entries) {
            let (child, entry) = (quad.child[k], entries[k]);
            if entry >= self.best {
                break;
            }
            if child == NONE {
                continue;
            }
            if child & LEAF != 0 {
                let id = child & !LEAF;
                let triangle = trimesh.triangle(id);
                if let Some(toi) = triangle.cast_local_ray(self.ray, self.best, false) {
                    if toi < self.best {
                        (self.best, self.hit) = (toi, Some(id));
                    }
                }
            } else if next.is_none() {
                next = Some(child);
            } else {
                later[count] = (child, entry);
                count += 1;
            }
        }
        // The farther put aside first, so that the nearer comes out first.
        for item in later[..count].iter().rev() {
            self.stack.push(*item);
        }
        self.current = next.or_else(|| pop_before(&mut self.stack, self.best));
        self.current.is_some()
    }

    fn hit(&self) -> Option<(u32, f64)> {
        self.hit.map(|id| (id, self.best))
    }
}

/// The four children's order by their entries, nearest first.
fn ascending(entries: &[f64; 4]) -> [usize; 4] {
    let mut order = [0, 1, 2, 3];
    for i in 1..4 {
        let mut j = i;
        while j > 0 && entries[order[j - 1]] > entries[order[j]] {
            order.swap(j - 1, j);
            j -= 1;
        }
    }
    order
}

/// The nodes put aside in a walk: on the call's stack up to 64 (a tree deeper than that is
/// rare), then on the heap.
struct Stack<T: Copy> {
    inline: [T; 64],
    len: usize,
    heap: Vec<T>,
}

impl<T: Copy> Stack<T> {
    fn new(zero: T) -> Self {
        Stack {
            inline: [zero; 64],
            len: 0,
            heap: Vec::new(),
        }
    }

    fn push(&mut self, item: T) {
        if self.len < self.inline.len() {
            self.inline[self.len] = item;
            self.len += 1;
        } else {
            self.heap.push(item);
        }
    }

    fn pop(&mut self) -> Option<T> {
        if let Some(item) = self.heap.pop() {
            return Some(item);
        }
        self.len = self.len.checked_sub(1)?;
        Some(self.inline[self.len])
    }
}

/// The last node put aside whose box is entered before `best`.
fn pop_before(stack: &mut Stack<(u32, f64)>, best: f64) -> Option<u32> {
    loop {
        let (n, entry) = stack.pop()?;
        if entry < best {
            return Some(n);
        }
    }
}

/// A ray prepared for box tests: its origin, and per axis the inverse of its direction and
/// which of a box's two planes it meets first (`None` where the direction is zero).
pub(crate) struct Slabs {
    origin: [f64; 3],
    inverse: [Option<(f64, bool)>; 3],
}

impl Slabs {
    pub(crate) fn new(ray: &Ray) -> Self {
        let d: Vector = ray.dir;
        let d = [d.x, d.y, d.z];
        Slabs {
            origin: [ray.origin.x, ray.origin.y, ray.origin.z],
            inverse: d.map(|d| (d != 0.0).then(|| (1.0 / d, d < 0.0))),
        }
    }

    /// When the ray enters a box (0 when it starts inside it), or `f64::MAX` when it misses it
    /// before `max`: parry's `Aabb::cast_local_ray` with `solid`, term for term (its two planes'
    /// times, the nearer kept, are the same numbers; it stops at the first axis that empties the
    /// interval, and the interval then stays empty).
    #[cfg(test)]
    fn entry_of(&self, mins: [f64; 3], maxs: [f64; 3], max: f64) -> f64 {
        let (mut near, mut far) = (0.0f64, max);
        for i in 0..3 {
            let o = self.origin[i];
            match self.inverse[i] {
                None if o < mins[i] || o > maxs[i] => return f64::MAX,
                None => {}
                Some((inverse, backwards)) => {
                    let (first, last) = if backwards {
                        (maxs[i], mins[i])
                    } else {
                        (mins[i], maxs[i])
                    };
                    near = near.max((first - o) * inverse);
                    far = far.min((last - o) * inverse);
                }
            }
        }
        if near > far {
            f64::MAX
        } else {
            near
        }
    }

    /// [`Self::entry_of`] for each of a node's four children's boxes, the same numbers, axis by
    /// axis for the four at once.
    #[inline(always)]
    fn entries(&self, quad: &Quad, max: f64) -> [f64; 4] {
        let mut near = [0.0f64; 4];
        let mut far = [max; 4];
        let mut outside = [false; 4];
        for axis in 0..3 {
            let o = self.origin[axis];
            let mins = quad.mins[axis].map(f64::from);
            let maxs = quad.maxs[axis].map(f64::from);
            match self.inverse[axis] {
                None => {
                    for k in 0..4 {
                        outside[k] |= o < mins[k] || o > maxs[k];
                    }
                }
                Some((inverse, backwards)) => {
                    let (first, last) = if backwards {
                        (maxs, mins)
                    } else {
                        (mins, maxs)
                    };
                    for k in 0..4 {
                        let (enter, leave) = ((first[k] - o) * inverse, (last[k] - o) * inverse);
                        near[k] = if enter > near[k] { enter } else { near[k] };
                        far[k] = if leave < far[k] { leave } else { far[k] };
                    }
                }
            }
        }
        std::array::from_fn(|k| {
            if outside[k] || near[k] > far[k] {
                f64::MAX
            } else {
                near[k]
            }
        })
    }
}

#[cfg(test)]
mod tests;

//! The precomputed hierarchy: strips, clusters and strand groups in one forest, stored as
//! structure-of-arrays with `u32` indices and `f32` geometry.
//!
//! Ward & Lin 2003 §4 (Fig. 4): one strip tree per root strip; a finest strip becomes a root
//! cluster, a finest cluster becomes a root strand group. Here each of those changes of
//! representation is its own node (one child with the same strands and a zero offset), so every
//! change of level, including a change of kind, is one step down or up one tree.

use crate::{Point, Real, Vector};
use core::ops::Range;
use hair_dynamics::{Material, Root, SkeletonDesc};
use nalgebra::Rotation3;

/// The representation of a node.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[repr(u8)]
pub enum NodeKind {
    /// A strip: a flat patch, split in two across its width (binary tree).
    Strip = 0,
    /// A cluster: a tube of circular cross-section, split into quadrants (quad tree).
    Cluster = 1,
    /// A strand group: the strands themselves around one skeleton, split into quadrants with
    /// the tightest circle around each, down to single strands or a minimum group size.
    StrandGroup = 2,
}

impl NodeKind {
    /// Lower-case name (`"strip"`, `"cluster"`, `"strand_group"`).
    pub fn name(self) -> &'static str {
        match self {
            NodeKind::Strip => "strip",
            NodeKind::Cluster => "cluster",
            NodeKind::StrandGroup => "strand_group",
        }
    }
}

/// The parent index of a tree's root.
pub const NO_PARENT: u32 = u32::MAX;

/// The strip / cluster / strand-group forest of a hairstyle.
///
/// Nodes are numbered tree by tree, breadth first inside a tree, so a tree's nodes are one
/// contiguous range and a node's children are contiguous. Each node's strands are a contiguous
/// range of one permutation of the strand ids, and its children's ranges partition it. Every
/// node of a tree has the tree's control-point count; a node stores its rest skeleton as an
/// offset per control point from its parent's (a tree's root stores its absolute points).
#[derive(Clone, Debug, PartialEq)]
pub struct Hierarchy {
    pub(crate) kind: Vec<NodeKind>,
    pub(crate) level: Vec<u8>,
    pub(crate) parent: Vec<u32>,
    pub(crate) first_child: Vec<u32>,
    pub(crate) child_count: Vec<u8>,
    pub(crate) strand_start: Vec<u32>,
    pub(crate) strand_count: Vec<u32>,
    pub(crate) size: Vec<Real>,
    pub(crate) cp_start: Vec<u32>,
    pub(crate) offsets: Vec<Vector>,
    pub(crate) tree: Vec<u32>,
    pub(crate) tree_start: Vec<u32>,
    pub(crate) frames: Vec<Rotation3<Real>>,
    pub(crate) strand_order: Vec<u32>,
    pub(crate) max_level: u8,
}

/// How many nodes of one kind sit at one level.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LevelCount {
    /// Level (depth in the tree; root strips are level 0).
    pub level: u8,
    /// Kind of the nodes.
    pub kind: NodeKind,
    /// How many.
    pub nodes: u32,
}

/// Size of a hierarchy: node counts per kind and level, and memory.
#[derive(Clone, Debug, PartialEq)]
pub struct HierarchyStats {
    /// Strands in the hairstyle.
    pub strands: u32,
    /// Control points per skeleton, averaged over trees weighted by strands.
    pub control_points: Real,
    /// Nodes in all.
    pub nodes: u32,
    /// Root strips (trees): the coarsest level.
    pub root_strips: u32,
    /// Root clusters (one per finest strip): the coarsest cluster level.
    pub root_clusters: u32,
    /// Root strand groups (one per finest cluster).
    pub root_strand_groups: u32,
    /// Leaves: skeletons simulated when everything is at its finest.
    pub finest_skeletons: u32,
    /// Strip nodes.
    pub strips: u32,
    /// Cluster nodes.
    pub clusters: u32,
    /// Strand-group nodes.
    pub strand_groups: u32,
    /// Deepest level.
    pub max_level: u8,
    /// Node counts per level and kind, sorted by level then kind.
    pub per_level: Vec<LevelCount>,
    /// Bytes held by the hierarchy.
    pub bytes: usize,
}

impl HierarchyStats {
    /// Bytes of hierarchy per strand of the hairstyle.
    pub fn bytes_per_strand(&self) -> f64 {
        self.bytes as f64 / f64::from(self.strands.max(1))
    }

    /// Mean strands per finest skeleton.
    pub fn strands_per_finest_skeleton(&self) -> f64 {
        f64::from(self.strands) / f64::from(self.finest_skeletons.max(1))
    }
}

impl Hierarchy {
    /// Number of nodes.
    pub fn node_count(&self) -> usize {
        self.kind.len()
    }

    /// Number of trees (root strips).
    pub fn tree_count(&self) -> usize {
        self.frames.len()
    }

    /// Number of strands.
    pub fn strand_total(&self) -> usize {
        self.strand_order.len()
    }

    /// Deepest level of any node.
    pub fn max_level(&self) -> u8 {
        self.max_level
    }

    /// Kind of a node.
    pub fn kind(&self, node: u32) -> NodeKind {
        self.kind[node as usize]
    }

    /// Level of a node: its depth in its tree (root strips are 0).
    pub fn level(&self, node: u32) -> u8 {
        self.level[node as usize]
    }

    /// Parent of a node, `None` for a root strip.
    pub fn parent(&self, node: u32) -> Option<u32> {
        let p = self.parent[node as usize];
        (p != NO_PARENT).then_some(p)
    }

    /// Children of a node (contiguous; empty for a leaf).
    pub fn children(&self, node: u32) -> Range<u32> {
        let f = self.first_child[node as usize];
        f..f + u32::from(self.child_count[node as usize])
    }

    /// Whether a node has no children.
    pub fn is_leaf(&self, node: u32) -> bool {
        self.child_count[node as usize] == 0
    }

    /// The strands a node stands for (ids into the hairstyle), for rendering.
    pub fn strands(&self, node: u32) -> &[u32] {
        let s = self.strand_start[node as usize] as usize;
        &self.strand_order[s..s + self.strand_count[node as usize] as usize]
    }

    /// How many strands a node stands for.
    pub fn strand_count(&self, node: u32) -> u32 {
        self.strand_count[node as usize]
    }

    /// Width of a strip, or radius of a cluster or strand group (m), across the scalp.
    pub fn size(&self, node: u32) -> Real {
        self.size[node as usize]
    }

    /// Control points of a node's skeleton (the same for every node of a tree).
    pub fn control_points(&self, node: u32) -> usize {
        (self.cp_start[node as usize + 1] - self.cp_start[node as usize]) as usize
    }

    /// Index of the node's first control point in per-control-point arrays over all nodes.
    pub fn control_point_start(&self, node: u32) -> usize {
        self.cp_start[node as usize] as usize
    }

    /// Where the node's control points lie in per-control-point arrays over all nodes.
    pub fn control_point_range(&self, node: u32) -> Range<usize> {
        self.cp_start[node as usize] as usize..self.cp_start[node as usize + 1] as usize
    }

    /// Control points of all nodes together (the length of per-control-point arrays).
    pub fn control_point_total(&self) -> usize {
        self.offsets.len()
    }

    /// Offsets of the node's rest skeleton from its parent's, per control point (m); a root
    /// strip's are its absolute points.
    pub fn offsets(&self, node: u32) -> &[Vector] {
        let s = self.cp_start[node as usize] as usize;
        &self.offsets[s..self.cp_start[node as usize + 1] as usize]
    }

    /// The tree a node belongs to.
    pub fn tree_of(&self, node: u32) -> u32 {
        self.tree[node as usize]
    }

    /// The root strip of a tree.
    pub fn tree_root(&self, tree: u32) -> u32 {
        self.tree_start[tree as usize]
    }

    /// The nodes of a tree (contiguous, breadth first).
    pub fn tree_nodes(&self, tree: u32) -> Range<u32> {
        self.tree_start[tree as usize]..self.tree_start[tree as usize + 1]
    }

    /// Root frame shared by every skeleton of a tree (z: the mean direction its hair leaves the
    /// scalp). Rest bend angles of the tree's skeletons are relative to it.
    pub fn tree_frame(&self, tree: u32) -> Rotation3<Real> {
        self.frames[tree as usize]
    }

    /// Rest skeleton of a node: its tree root's points plus the offsets down to it.
    pub fn rest_points_into(&self, node: u32, out: &mut Vec<Point>) {
        out.clear();
        let n = self.control_points(node);
        out.resize(n, Point::origin());
        let mut cur = Some(node);
        while let Some(c) = cur {
            for (o, d) in out.iter_mut().zip(self.offsets(c)) {
                o.coords += d;
            }
            cur = self.parent(c);
        }
    }

    /// Rest skeleton of a node (allocates; see [`Hierarchy::rest_points_into`]).
    pub fn rest_points(&self, node: u32) -> Vec<Point> {
        let mut out = Vec::new();
        self.rest_points_into(node, &mut out);
        out
    }

    /// A `hair-dynamics` skeleton for a node: attached at its rest root with its tree's frame.
    /// The skeleton's rest angles are then the ones [`crate::LodState`] deviations are measured
    /// from.
    pub fn skeleton_desc(&self, node: u32, material: Material) -> SkeletonDesc {
        let points = self.rest_points(node);
        SkeletonDesc {
            root: Root::Attached {
                position: points[0],
                frame: self.tree_frame(self.tree_of(node)),
            },
            points,
            material,
        }
    }

    /// For every strand, its leaf (finest) node.
    pub fn leaf_of_strands(&self) -> Vec<u32> {
        let mut out = vec![0; self.strand_order.len()];
        for n in 0..self.node_count() as u32 {
            if self.is_leaf(n) {
                for &s in self.strands(n) {
                    out[s as usize] = n;
                }
            }
        }
        out
    }

    /// Checks a node index.
    pub fn check(&self, node: u32) -> Result<(), crate::LodError> {
        if (node as usize) < self.node_count() {
            Ok(())
        } else {
            Err(crate::LodError::UnknownNode {
                node,
                count: self.node_count(),
            })
        }
    }

    /// Bytes held by the hierarchy (every array, by capacity).
    pub fn memory_bytes(&self) -> usize {
        use core::mem::size_of;
        self.kind.capacity() * size_of::<NodeKind>()
            + self.level.capacity()
            + self.parent.capacity() * 4
            + self.first_child.capacity() * 4
            + self.child_count.capacity()
            + self.strand_start.capacity() * 4
            + self.strand_count.capacity() * 4
            + self.size.capacity() * size_of::<Real>()
            + self.cp_start.capacity() * 4
            + self.offsets.capacity() * size_of::<Vector>()
            + self.tree.capacity() * 4
            + self.tree_start.capacity() * 4
            + self.frames.capacity() * size_of::<Rotation3<Real>>()
            + self.strand_order.capacity() * 4
            + size_of::<Self>()
    }

    /// Node counts per kind and level, and memory.
    pub fn stats(&self) -> HierarchyStats {
        let mut per = std::collections::BTreeMap::<(u8, NodeKind), u32>::new();
        let (mut strips, mut clusters, mut groups) = (0, 0, 0);
        let (mut root_clusters, mut root_groups, mut leaves) = (0, 0, 0);
        for n in 0..self.node_count() as u32 {
            let k = self.kind(n);
            *per.entry((self.level(n), k)).or_default() += 1;
            match k {
                NodeKind::Strip => strips += 1,
                NodeKind::Cluster => clusters += 1,
                NodeKind::StrandGroup => groups += 1,
            }
            if let Some(p) = self.parent(n) {
                if k == NodeKind::Cluster && self.kind(p) == NodeKind::Strip {
                    root_clusters += 1;
                }
                if k == NodeKind::StrandGroup && self.kind(p) == NodeKind::Cluster {
                    root_groups += 1;
                }
            }
            if self.is_leaf(n) {
                leaves += 1;
            }
        }
        let mut cp_weighted = 0.0f64;
        for t in 0..self.tree_count() as u32 {
            let r = self.tree_root(t);
            cp_weighted += self.control_points(r) as f64 * f64::from(self.strand_count(r));
        }
        HierarchyStats {
            strands: self.strand_order.len() as u32,
            control_points: (cp_weighted / self.strand_order.len().max(1) as f64) as Real,
            nodes: self.node_count() as u32,
            root_strips: self.tree_count() as u32,
            root_clusters,
            root_strand_groups: root_groups,
            finest_skeletons: leaves,
            strips,
            clusters,
            strand_groups: groups,
            max_level: self.max_level,
            per_level: per
                .into_iter()
                .map(|((level, kind), nodes)| LevelCount { level, kind, nodes })
                .collect(),
            bytes: self.memory_bytes(),
        }
    }
}

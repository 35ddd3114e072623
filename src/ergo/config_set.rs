//! Feasible sets of arm configurations, stored joint-major for fast cost evaluation.

use std::ops::Range;
use std::sync::OnceLock;

use super::lanes::WIDTH;
use super::lanes_f32::WIDTH_F32;

/// Why a set of configurations was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ConfigSetError {
    #[error("a feasible set needs at least one configuration")]
    Empty,
    #[error("configuration {index} has {found} joints, expected {expected}")]
    DimensionMismatch { index: usize, found: usize, expected: usize },
    #[error("configuration {index} joint {joint} is {value}, expected a finite number")]
    NonFinite { index: usize, joint: usize, value: f64 },
    #[error("{found} region labels for {expected} configurations")]
    LabelCount { found: usize, expected: usize },
    #[error("configurations of region {region} are not contiguous (configuration {index})")]
    RegionsNotContiguous { region: usize, index: usize },
}

/// A non-empty set of configurations of D joints.
#[derive(Clone, Debug)]
pub struct ConfigSet {
    dim: usize,
    len: usize,
    /// Joint-major, each joint padded with zeros to whole blocks of [`WIDTH`] (the set
    /// pass's): joint d of configuration j is `data[d * stride + j]`.
    data: Vec<f64>,
    stride: usize,
    /// The same rounded to f32, padded to whole blocks of [`WIDTH_F32`] (the float32
    /// pass's), made when a float32 pass first asks for it, so a float64 program never
    /// pays for it: joint d of configuration j is at `d * stride_f32() + j`.
    data_f32: OnceLock<Vec<f32>>,
    /// Each joint's range over every group of [`GROUP`] configurations, made when the
    /// bounded minimum ([`super::SetPass::min_cost`]) first asks for it.
    boxes: OnceLock<Box<GroupBoxes>>,
}

/// Configurations a [`GroupBoxes`] box holds: two blocks of [`WIDTH`].
pub(super) const GROUP: usize = 2 * WIDTH;

/// The set's configurations reordered so that every group of [`GROUP`] consecutive ones
/// lies close together (the leaves of a k-d tree: each split halves the widest joint's
/// range at its median, on a multiple of [`GROUP`]), with the smallest box around each
/// group: joint d of group g spans `lo[d * groups + g] ..= hi[d * groups + g]`. A minimum
/// over the set is the minimum over `sorted` (the same configurations).
#[derive(Clone, Debug)]
pub(super) struct GroupBoxes {
    pub sorted: ConfigSet,
    pub groups: usize,
    pub lo: Vec<f64>,
    pub hi: Vec<f64>,
    /// max_j |q_jd| per joint: what bounds the rounding of a cost.
    pub reach: Vec<f64>,
}

impl GroupBoxes {
    fn of(set: &ConfigSet) -> Self {
        let mut order: Vec<usize> = (0..set.len).collect();
        leaf_order(set, &mut order);
        let rows: Vec<Vec<f64>> = order.iter().map(|&j| set.config(j)).collect();
        // The rows of a valid set make a valid set.
        let sorted = ConfigSet::from_rows(&rows).unwrap_or_else(|_| set.clone());
        let groups = set.len.div_ceil(GROUP);
        let (mut lo, mut hi) = (Vec::with_capacity(set.dim * groups), Vec::with_capacity(set.dim * groups));
        for d in 0..set.dim {
            for g in sorted.joint(d).chunks(GROUP) {
                lo.push(g.iter().copied().fold(f64::INFINITY, f64::min));
                hi.push(g.iter().copied().fold(f64::NEG_INFINITY, f64::max));
            }
        }
        let reach = (0..set.dim).map(|d| set.joint(d).iter().fold(0.0, |m: f64, q| m.max(q.abs()))).collect();
        GroupBoxes { sorted, groups, lo, hi, reach }
    }
}

/// Orders `idx` as the leaves of a k-d tree with leaves of [`GROUP`] configurations.
fn leaf_order(set: &ConfigSet, idx: &mut [usize]) {
    if idx.len() <= GROUP {
        return;
    }
    let widest = (0..set.dim)
        .map(|d| {
            let v = set.joint(d);
            let (lo, hi) = idx.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &j| (l.min(v[j]), h.max(v[j])));
            (hi - lo, d)
        })
        .fold((f64::NEG_INFINITY, 0), |best, c| if c.0 > best.0 { c } else { best })
        .1;
    let v = set.joint(widest);
    let mid = (idx.len() / 2).div_ceil(GROUP) * GROUP;
    idx.select_nth_unstable_by(mid, |&a, &b| v[a].total_cmp(&v[b]));
    let (left, right) = idx.split_at_mut(mid);
    leaf_order(set, left);
    leaf_order(set, right);
}

/// Equal sets hold the same configurations, whether or not either has made its f32 copy or
/// its boxes.
impl PartialEq for ConfigSet {
    fn eq(&self, other: &Self) -> bool {
        (self.dim, self.len, self.stride, &self.data) == (other.dim, other.len, other.stride, &other.data)
    }
}

impl ConfigSet {
    /// Builds a set from configurations given one per row.
    pub fn from_rows<R: AsRef<[f64]>>(rows: &[R]) -> Result<Self, ConfigSetError> {
        let first = rows.first().ok_or(ConfigSetError::Empty)?;
        let dim = first.as_ref().len();
        let len = rows.len();
        let stride = len.div_ceil(WIDTH) * WIDTH;
        let mut data = vec![0.0; dim * stride];
        for (j, row) in rows.iter().enumerate() {
            let row = row.as_ref();
            if row.len() != dim {
                return Err(ConfigSetError::DimensionMismatch { index: j, found: row.len(), expected: dim });
            }
            for (d, &v) in row.iter().enumerate() {
                if !v.is_finite() {
                    return Err(ConfigSetError::NonFinite { index: j, joint: d, value: v });
                }
                data[d * stride + j] = v;
            }
        }
        Ok(Self { dim, len, data, stride, data_f32: OnceLock::new(), boxes: OnceLock::new() })
    }

    /// Number of joints D.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// Number of configurations (never zero).
    pub fn len(&self) -> usize {
        self.len
    }

    /// Always false: a set holds at least one configuration.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Joint d of every configuration.
    pub fn joint(&self, d: usize) -> &[f64] {
        &self.data[d * self.stride..d * self.stride + self.len]
    }

    /// Joint d of every configuration in blocks of [`WIDTH`], the last one padded with zeros.
    pub(super) fn joint_blocks(&self, d: usize) -> &[[f64; WIDTH]] {
        self.data[d * self.stride..(d + 1) * self.stride].as_chunks().0
    }

    /// Joint d of every configuration rounded to f32, in blocks of [`WIDTH_F32`], the last
    /// one padded with zeros.
    pub(super) fn joint_blocks_f32(&self, d: usize) -> &[[f32; WIDTH_F32]] {
        let stride = self.len.div_ceil(WIDTH_F32) * WIDTH_F32;
        let data = self.data_f32.get_or_init(|| {
            let mut out = vec![0.0; self.dim * stride];
            for d in 0..self.dim {
                for (o, &v) in out[d * stride..].iter_mut().zip(self.joint(d)) {
                    *o = v as f32;
                }
            }
            out
        });
        data[d * stride..(d + 1) * stride].as_chunks().0
    }

    /// The set reordered in groups of nearby configurations, with each group's box.
    pub(super) fn group_boxes(&self) -> &GroupBoxes {
        self.boxes.get_or_init(|| Box::new(GroupBoxes::of(self)))
    }

    /// max_j |q_jd| for every joint d: what bounds the rounding of a cost.
    pub fn reach(&self) -> &[f64] {
        &self.group_boxes().reach
    }

    /// Configuration j as a vector of D joint angles.
    pub fn config(&self, j: usize) -> Vec<f64> {
        (0..self.dim).map(|d| self.data[d * self.stride + j]).collect()
    }
}

/// A query's feasible set: its configurations and, for each, the region (handle) it grasps.
///
/// Configurations of one region are contiguous, so a region is a range of indices.
#[derive(Clone, Debug, PartialEq)]
pub struct FeasibleSet {
    configs: ConfigSet,
    regions: Vec<Range<usize>>,
}

impl FeasibleSet {
    /// A set in which every configuration is its own outcome and all form one region.
    pub fn new(configs: ConfigSet) -> Self {
        let regions = std::iter::once(0..configs.len()).collect();
        Self { configs, regions }
    }

    /// A set with region labels 0..R, one per configuration, grouped contiguously.
    pub fn with_regions(configs: ConfigSet, labels: &[usize]) -> Result<Self, ConfigSetError> {
        if labels.len() != configs.len() {
            return Err(ConfigSetError::LabelCount { found: labels.len(), expected: configs.len() });
        }
        let count = labels.iter().copied().max().map_or(0, |m| m + 1);
        let mut regions = vec![0..0; count];
        let mut seen = vec![false; count];
        let mut start = 0;
        for j in 1..=labels.len() {
            if j == labels.len() || labels[j] != labels[start] {
                let r = labels[start];
                if seen[r] {
                    return Err(ConfigSetError::RegionsNotContiguous { region: r, index: start });
                }
                seen[r] = true;
                regions[r] = start..j;
                start = j;
            }
        }
        Ok(Self { configs, regions })
    }

    pub fn configs(&self) -> &ConfigSet {
        &self.configs
    }

    /// The index range of each region; a region with no configuration is an empty range.
    pub fn regions(&self) -> &[Range<usize>] {
        &self.regions
    }

    /// The region that configuration j belongs to.
    pub fn region_of(&self, j: usize) -> usize {
        self.regions.iter().position(|r| r.contains(&j)).unwrap_or(0)
    }

    pub fn len(&self) -> usize {
        self.configs.len()
    }

    pub fn is_empty(&self) -> bool {
        self.configs.is_empty()
    }

    pub fn dim(&self) -> usize {
        self.configs.dim()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_are_stored_and_read_back() {
        let s = ConfigSet::from_rows(&[vec![1.0, 2.0], vec![3.0, 4.0], vec![5.0, 6.0]]).unwrap();
        assert_eq!(s.joint(1), &[2.0, 4.0, 6.0]);
        assert_eq!(s.config(2), vec![5.0, 6.0]);
    }

    #[test]
    fn bad_sets_are_refused_with_their_facts() {
        let empty: Vec<Vec<f64>> = vec![];
        assert_eq!(ConfigSet::from_rows(&empty), Err(ConfigSetError::Empty));
        assert_eq!(
            ConfigSet::from_rows(&[vec![1.0, 2.0], vec![3.0]]),
            Err(ConfigSetError::DimensionMismatch { index: 1, found: 1, expected: 2 })
        );
        assert!(matches!(
            ConfigSet::from_rows(&[vec![f64::NAN]]),
            Err(ConfigSetError::NonFinite { index: 0, joint: 0, .. })
        ));
    }

    #[test]
    fn regions_must_be_contiguous() {
        let c = ConfigSet::from_rows(&[[0.0], [1.0], [2.0]]).unwrap();
        let s = FeasibleSet::with_regions(c.clone(), &[0, 0, 1]).unwrap();
        assert_eq!(s.regions(), &[0..2, 2..3]);
        assert_eq!(s.region_of(2), 1);
        assert!(matches!(
            FeasibleSet::with_regions(c, &[0, 1, 0]),
            Err(ConfigSetError::RegionsNotContiguous { region: 0, index: 2 })
        ));
    }
}

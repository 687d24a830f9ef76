//! Label maps kept as runs of equal values, so every view's final map can wait in memory for the
//! steps that need all views (the give-back of unowned ids, the speck filter, the numbering)
//! at a small part of its `[H, W]` size.

use splatseg_scene::Plane;

/// A label map as runs of equal values in row-major order: `[n_runs]` (value, length).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RunLengths {
    /// Width of the map.
    pub width: usize,
    /// Height of the map.
    pub height: usize,
    /// `[n_runs]` (value, length), lengths summing to `width · height`.
    pub runs: Vec<(u32, u32)>,
}

impl RunLengths {
    /// The runs of `map`.
    pub fn encode(map: &Plane<u32>) -> RunLengths {
        let mut runs: Vec<(u32, u32)> = Vec::new();
        for &v in &map.data {
            match runs.last_mut() {
                Some((last, n)) if *last == v && *n < u32::MAX => *n += 1,
                _ => runs.push((v, 1)),
            }
        }
        RunLengths { width: map.width, height: map.height, runs }
    }

    /// The map, each value passed through `f`.
    pub fn decode(&self, f: impl Fn(u32) -> u32) -> Plane<u32> {
        let mut data = Vec::with_capacity(self.width * self.height);
        for &(v, n) in &self.runs {
            data.extend(std::iter::repeat_n(f(v), n as usize));
        }
        Plane { width: self.width, height: self.height, data }
    }

    /// Ids (> 0) in order of first appearance, without those `skip` names.
    pub(crate) fn first_appearance(&self, skip: impl Fn(u32) -> bool) -> Vec<u32> {
        let mut seen = std::collections::BTreeSet::new();
        self.runs.iter().map(|&(v, _)| v).filter(|&v| v > 0 && !skip(v) && seen.insert(v)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_decode_to_the_map_and_list_ids_by_first_appearance() {
        let map = Plane { width: 4, height: 3, data: vec![0, 7, 7, 3, 3, 3, 9, 0, 5, 5, 5, 5] };
        let runs = RunLengths::encode(&map);
        assert_eq!(runs.runs, vec![(0, 1), (7, 2), (3, 3), (9, 1), (0, 1), (5, 4)]);
        assert_eq!(runs.decode(|id| id), map);
        assert_eq!(runs.decode(|id| id * 2).data[1], 14);
        assert_eq!(runs.first_appearance(|id| id == 9), vec![7, 3, 5]);
    }
}

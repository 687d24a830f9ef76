//! 4-connected components of pixel sets, the building block of the simulated SAM masks.

/// The 4-connected components of the pixels where `key(i)` is `Some(k)` with equal `k`.
/// `width`, `height`: the image; pixel `i = y · width + x`. Components come in scan order of
/// their first pixel, each as its pixel indices in ascending order.
pub fn components_by_key<K: PartialEq + Copy>(
    width: usize,
    height: usize,
    key: impl Fn(usize) -> Option<K>,
) -> Vec<Vec<u32>> {
    let n = width * height;
    let mut seen = vec![false; n];
    let mut out = Vec::new();
    let mut stack = Vec::new();
    for start in 0..n {
        if seen[start] {
            continue;
        }
        let Some(k) = key(start) else { continue };
        seen[start] = true;
        stack.push(start);
        let mut pixels = Vec::new();
        while let Some(i) = stack.pop() {
            pixels.push(i as u32);
            let (x, y) = (i % width, i / width);
            let mut visit = |j: usize| {
                if !seen[j] && key(j) == Some(k) {
                    seen[j] = true;
                    stack.push(j);
                }
            };
            if x > 0 {
                visit(i - 1);
            }
            if x + 1 < width {
                visit(i + 1);
            }
            if y > 0 {
                visit(i - width);
            }
            if y + 1 < height {
                visit(i + width);
            }
        }
        pixels.sort_unstable();
        out.push(pixels);
    }
    out
}

/// The 4-connected components of a pixel set (`pixels`: indices into a `width × height` image).
/// `scratch`: `[width · height]`, all `false` on entry and on return.
pub fn split_connected(pixels: &[u32], width: usize, height: usize, scratch: &mut [bool]) -> Vec<Vec<u32>> {
    for &p in pixels {
        scratch[p as usize] = true;
    }
    let mut out = Vec::new();
    let mut stack = Vec::new();
    for &start in pixels {
        if !scratch[start as usize] {
            continue;
        }
        scratch[start as usize] = false;
        stack.push(start as usize);
        let mut comp = Vec::new();
        while let Some(i) = stack.pop() {
            comp.push(i as u32);
            let (x, y) = (i % width, i / width);
            let neighbours = [
                (x > 0).then(|| i - 1),
                (x + 1 < width).then(|| i + 1),
                (y > 0).then(|| i - width),
                (y + 1 < height).then(|| i + width),
            ];
            for j in neighbours.into_iter().flatten() {
                if scratch[j] {
                    scratch[j] = false;
                    stack.push(j);
                }
            }
        }
        comp.sort_unstable();
        out.push(comp);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_separate_components_of_equal_keys() {
        // 5×3 image: key 1 on columns 0 and 4 (two components), key 2 in between.
        let keys = [1, 2, 2, 2, 1, 1, 2, 0, 2, 1, 1, 2, 2, 2, 1];
        let comps = components_by_key(5, 3, |i| (keys[i] != 0).then_some(keys[i]));
        assert_eq!(comps.len(), 3);
        assert_eq!(comps[0], vec![0, 5, 10]);
        assert_eq!(comps[1], vec![1, 2, 3, 6, 8, 11, 12, 13]);
        assert_eq!(comps[2], vec![4, 9, 14]);
    }

    #[test]
    fn split_connected_separates_and_restores_scratch() {
        let mut scratch = vec![false; 16];
        let comps = split_connected(&[0, 1, 4, 10, 11, 15], 4, 4, &mut scratch);
        assert_eq!(comps, vec![vec![0, 1, 4], vec![10, 11, 15]]);
        assert!(scratch.iter().all(|s| !s));
    }
}

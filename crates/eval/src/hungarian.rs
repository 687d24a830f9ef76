//! Optimal assignment (Kuhn–Munkres with potentials, the shortest-augmenting-path form of
//! Jonker–Volgenant) on real-valued, possibly rectangular matrices.
//!
//! Work is `O(n² m)` for `n = min(rows, cols)`, `m = max(rows, cols)`: rows are added one at a
//! time and each addition runs a Dijkstra-like search over the columns with reduced costs.
//! Ties are broken by the lowest column index, so results are deterministic.

use crate::error::EvalError;

/// Assigns rows to columns so that the sum of the weights of the chosen pairs is as large as
/// possible, each row and each column used at most once, and `min(rows, cols)` pairs chosen.
///
/// `weights`: `[rows, cols]` row-major. Returns `[rows]`: the column of each row, `None` for the
/// rows left over when `rows > cols`. Callers that need "unmatched" for zero-weight pairs filter
/// them afterwards.
pub fn max_weight_assignment(
    weights: &[f64],
    rows: usize,
    cols: usize,
) -> Result<Vec<Option<usize>>, EvalError> {
    if weights.len() != rows * cols {
        return Err(EvalError::BadMatrixShape { rows, cols, len: weights.len() });
    }
    if let Some(i) = weights.iter().position(|w| !w.is_finite()) {
        return Err(EvalError::NonFiniteWeight { row: i / cols, col: i % cols, value: weights[i] });
    }
    if rows == 0 || cols == 0 {
        return Ok(vec![None; rows]);
    }
    if rows <= cols {
        let cost: Vec<f64> = weights.iter().map(|w| -w).collect();
        Ok(min_cost_rows_le_cols(&cost, rows, cols).into_iter().map(Some).collect())
    } else {
        // Transpose so the short side is the rows, then invert the result.
        let mut cost = vec![0.0; rows * cols];
        for r in 0..rows {
            for c in 0..cols {
                cost[c * rows + r] = -weights[r * cols + c];
            }
        }
        let col_to_row = min_cost_rows_le_cols(&cost, cols, rows);
        let mut out = vec![None; rows];
        for (c, r) in col_to_row.into_iter().enumerate() {
            out[r] = Some(c);
        }
        Ok(out)
    }
}

/// Maximum-weight matching for a sparse non-negative matrix: `entries` are `(row, col, weight)`
/// with weight > 0 (absent pairs weigh 0 and are never matched). Returns `[rows]`: the column of
/// each matched row. The bipartite graph of the entries is split into connected components,
/// each solved densely, so cost follows the largest component rather than `rows × cols`.
/// Results equal the dense solution's total weight.
pub fn max_weight_matching_sparse(
    entries: &[(usize, usize, f64)],
    rows: usize,
    cols: usize,
) -> Result<Vec<Option<usize>>, EvalError> {
    if let Some(&(row, col, value)) = entries.iter().find(|e| !e.2.is_finite() || e.0 >= rows || e.1 >= cols)
    {
        return Err(EvalError::NonFiniteWeight { row, col, value });
    }
    // Union-find over rows (0..rows) and columns (rows..rows + cols).
    let mut parent: Vec<usize> = (0..rows + cols).collect();
    fn find(parent: &mut [usize], mut x: usize) -> usize {
        while parent[x] != x {
            parent[x] = parent[parent[x]];
            x = parent[x];
        }
        x
    }
    for &(r, c, w) in entries {
        if w > 0.0 {
            let (a, b) = (find(&mut parent, r), find(&mut parent, rows + c));
            if a != b {
                parent[a.max(b)] = a.min(b);
            }
        }
    }
    // Group the positive entries by component, in a fixed order.
    let mut by_root: std::collections::BTreeMap<usize, Vec<(usize, usize, f64)>> = Default::default();
    for &(r, c, w) in entries {
        if w > 0.0 {
            let root = find(&mut parent, r);
            by_root.entry(root).or_default().push((r, c, w));
        }
    }
    let mut out = vec![None; rows];
    for (_, comp) in by_root {
        let mut comp_rows: Vec<usize> = comp.iter().map(|e| e.0).collect();
        let mut comp_cols: Vec<usize> = comp.iter().map(|e| e.1).collect();
        comp_rows.sort_unstable();
        comp_rows.dedup();
        comp_cols.sort_unstable();
        comp_cols.dedup();
        let (nr, nc) = (comp_rows.len(), comp_cols.len());
        let mut dense = vec![0.0; nr * nc];
        for &(r, c, w) in &comp {
            // Both searches succeed: the lists were built from these entries.
            if let (Ok(i), Ok(j)) = (comp_rows.binary_search(&r), comp_cols.binary_search(&c)) {
                dense[i * nc + j] += w;
            }
        }
        for (i, j) in max_weight_assignment(&dense, nr, nc)?.into_iter().enumerate() {
            if let Some(j) = j.filter(|&j| dense[i * nc + j] > 0.0) {
                out[comp_rows[i]] = Some(comp_cols[j]);
            }
        }
    }
    Ok(out)
}

/// Minimum-cost assignment of every row for `n <= m`. `cost`: `[n, m]` row-major, finite.
/// Returns `[n]` column indices.
fn min_cost_rows_le_cols(cost: &[f64], n: usize, m: usize) -> Vec<usize> {
    debug_assert!(n <= m);
    // Index 0 of the column arrays is a virtual column holding the row being inserted;
    // rows and columns are 1-based inside this function.
    let mut row_potential = vec![0.0f64; n + 1];
    let mut col_potential = vec![0.0f64; m + 1];
    let mut row_of_col = vec![0usize; m + 1];
    let mut prev_col = vec![0usize; m + 1];
    let mut min_reduced = vec![f64::INFINITY; m + 1];
    let mut visited = vec![false; m + 1];
    for row in 1..=n {
        row_of_col[0] = row;
        let mut col0 = 0usize;
        min_reduced.fill(f64::INFINITY);
        visited.fill(false);
        loop {
            visited[col0] = true;
            let r0 = row_of_col[col0];
            let mut delta = f64::INFINITY;
            let mut next_col = 0usize;
            let cost_row = &cost[(r0 - 1) * m..r0 * m];
            for col in 1..=m {
                if visited[col] {
                    continue;
                }
                let reduced = cost_row[col - 1] - row_potential[r0] - col_potential[col];
                if reduced < min_reduced[col] {
                    min_reduced[col] = reduced;
                    prev_col[col] = col0;
                }
                if min_reduced[col] < delta {
                    delta = min_reduced[col];
                    next_col = col;
                }
            }
            for col in 0..=m {
                if visited[col] {
                    row_potential[row_of_col[col]] += delta;
                    col_potential[col] -= delta;
                } else {
                    min_reduced[col] -= delta;
                }
            }
            col0 = next_col;
            if row_of_col[col0] == 0 {
                break;
            }
        }
        // Augment along the alternating path back to the virtual column.
        loop {
            let col1 = prev_col[col0];
            row_of_col[col0] = row_of_col[col1];
            col0 = col1;
            if col0 == 0 {
                break;
            }
        }
    }
    let mut col_of_row = vec![0usize; n];
    for col in 1..=m {
        if row_of_col[col] != 0 {
            col_of_row[row_of_col[col] - 1] = col - 1;
        }
    }
    col_of_row
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn total(weights: &[f64], cols: usize, assignment: &[Option<usize>]) -> f64 {
        assignment.iter().enumerate().filter_map(|(r, c)| c.map(|c| weights[r * cols + c])).sum()
    }

    /// Best total over all injective maps from the short side into the long side.
    fn brute_force_best(weights: &[f64], rows: usize, cols: usize) -> f64 {
        fn rec(w: &[f64], rows: usize, cols: usize, r: usize, used: &mut Vec<bool>) -> f64 {
            if r == rows {
                return 0.0;
            }
            let mut best = f64::NEG_INFINITY;
            let free_cols = used.iter().filter(|u| !**u).count();
            // A row may stay unassigned only when there are more rows than columns.
            if rows - r > free_cols {
                best = rec(w, rows, cols, r + 1, used);
            }
            for c in 0..cols {
                if !used[c] {
                    used[c] = true;
                    best = best.max(w[r * cols + c] + rec(w, rows, cols, r + 1, used));
                    used[c] = false;
                }
            }
            best
        }
        rec(weights, rows, cols, 0, &mut vec![false; cols])
    }

    fn assert_valid(assignment: &[Option<usize>], rows: usize, cols: usize) {
        let mut seen = vec![false; cols];
        let assigned = assignment.iter().flatten().count();
        assert_eq!(assigned, rows.min(cols));
        for c in assignment.iter().flatten() {
            assert!(!seen[*c], "column {c} used twice");
            seen[*c] = true;
        }
    }

    #[test]
    fn beats_greedy_where_greedy_is_wrong() {
        // Greedy takes the single best pair (0,0)=0.9 and is left with (1,1)=0.0: total 0.9.
        // The optimum pairs (0,1) and (1,0): 0.8 + 0.7 = 1.5.
        let w = [0.9, 0.8, 0.7, 0.0];
        let a = max_weight_assignment(&w, 2, 2).unwrap();
        assert_eq!(a, vec![Some(1), Some(0)]);
        assert!((total(&w, 2, &a) - 1.5).abs() < 1e-12);
    }

    #[test]
    fn wide_matrix_assigns_every_row() {
        // 2 rows, 4 columns: row 0 prefers col 3, row 1 prefers col 3 more; row 0 falls back to col 1.
        let w = [0.1, 0.5, 0.0, 0.6, 0.0, 0.2, 0.0, 0.9];
        let a = max_weight_assignment(&w, 2, 4).unwrap();
        assert_eq!(a, vec![Some(1), Some(3)]);
    }

    #[test]
    fn tall_matrix_leaves_rows_unassigned() {
        // 3 rows, 1 column: only the best row gets it.
        let w = [0.2, 0.7, 0.4];
        let a = max_weight_assignment(&w, 3, 1).unwrap();
        assert_eq!(a, vec![None, Some(0), None]);
        // 3 rows, 2 columns where the greedy choice (row 1, col 0) = 0.9 is wrong.
        let w = [0.8, 0.0, 0.9, 0.85, 0.0, 0.1];
        let a = max_weight_assignment(&w, 3, 2).unwrap();
        assert_eq!(a, vec![Some(0), Some(1), None]);
    }

    #[test]
    fn ties_are_deterministic_and_optimal() {
        let w = [1.0; 9];
        let a = max_weight_assignment(&w, 3, 3).unwrap();
        assert_valid(&a, 3, 3);
        assert_eq!(a, max_weight_assignment(&w, 3, 3).unwrap());
        assert!((total(&w, 3, &a) - 3.0).abs() < 1e-12);
        let zeros = [0.0; 6];
        let a = max_weight_assignment(&zeros, 2, 3).unwrap();
        assert_valid(&a, 2, 3);
    }

    #[test]
    fn empty_and_invalid_inputs() {
        assert_eq!(max_weight_assignment(&[], 0, 5).unwrap(), Vec::<Option<usize>>::new());
        assert_eq!(max_weight_assignment(&[], 3, 0).unwrap(), vec![None; 3]);
        assert!(matches!(max_weight_assignment(&[1.0; 5], 2, 3), Err(EvalError::BadMatrixShape { .. })));
        let err = max_weight_assignment(&[1.0, f64::NAN, 0.0, 0.0], 2, 2).unwrap_err();
        assert!(matches!(err, EvalError::NonFiniteWeight { row: 0, col: 1, .. }));
    }

    #[test]
    fn sparse_matching_equals_dense_total() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        for trial in 0..200 {
            let rows = rng.gen_range(1..=7);
            let cols = rng.gen_range(1..=7);
            let w: Vec<f64> = (0..rows * cols)
                .map(|_| if rng.gen_bool(0.7) { 0.0 } else { rng.gen_range(1..5) as f64 * 0.2 })
                .collect();
            let entries: Vec<(usize, usize, f64)> =
                (0..rows * cols).filter(|&k| w[k] > 0.0).map(|k| (k / cols, k % cols, w[k])).collect();
            let sparse = max_weight_matching_sparse(&entries, rows, cols).unwrap();
            let mut used = vec![false; cols];
            for c in sparse.iter().flatten() {
                assert!(!used[*c], "trial {trial}: column used twice");
                used[*c] = true;
            }
            assert!(sparse.iter().enumerate().all(|(r, c)| c.is_none_or(|c| w[r * cols + c] > 0.0)));
            let best = brute_force_best(&w, rows, cols);
            assert!((total(&w, cols, &sparse) - best).abs() < 1e-9, "trial {trial}: {w:?}");
        }
        let bad = max_weight_matching_sparse(&[(0, 3, 1.0)], 1, 2);
        assert!(bad.is_err());
    }

    #[test]
    fn matches_brute_force_on_random_matrices() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        for trial in 0..300 {
            let rows = rng.gen_range(1..=6);
            let cols = rng.gen_range(1..=6);
            // Coarse values make ties frequent.
            let coarse = trial % 2 == 0;
            let w: Vec<f64> = (0..rows * cols)
                .map(|_| if coarse { rng.gen_range(0..4) as f64 * 0.25 } else { rng.gen_range(-1.0..1.0) })
                .collect();
            let a = max_weight_assignment(&w, rows, cols).unwrap();
            assert_valid(&a, rows, cols);
            let best = brute_force_best(&w, rows, cols);
            let got = total(&w, cols, &a);
            assert!(
                (got - best).abs() < 1e-9,
                "trial {trial}: {rows}x{cols} got {got}, best {best}, w={w:?}"
            );
        }
    }
}

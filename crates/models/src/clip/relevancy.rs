//! Ranking object embeddings against a text query, as LERF scores relevancy (Kerr et al. 2023, "LERF:
//! Language Embedded Radiance Fields", §3.4; LangSplat scores the same way).
//!
//! With `φ` an object's embedding, `q` the query's and `n₁ … n_M` the canonical phrases' ("object",
//! "things", "stuff", "texture"), all L2-normalised, and `s` the softmax scale:
//!
//! ```text
//! relevancy(φ) = min_j  exp(s·φ·q) / (exp(s·φ·q) + exp(s·φ·n_j))  =  min_j σ(s·(φ·q − φ·n_j))
//! ```
//!
//! The paper writes the pairwise softmax without a scale; LERF's implementation (and LangSplat's)
//! multiplies the cosines by 10 before it ([`LERF_SCALE`], a temperature of 0.1). A relevancy above 0.5
//! means the object is closer to the query than to every canonical phrase.
//!
//! Objects are ranked by relevancy, highest first; equal relevancies by id, lowest first. The
//! arithmetic is sequential, so the ranking does not depend on the thread count.

use crate::error::{ModelsError, ModelsResult};

/// LERF's canonical negative phrases.
pub const CANONICAL_NEGATIVES: [&str; 4] = ["object", "things", "stuff", "texture"];
/// The factor LERF's implementation applies to the cosines before the pairwise softmax.
pub const LERF_SCALE: f32 = 10.0;

/// One ranked object.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RankedObject {
    /// The object's id.
    pub id: u32,
    /// Its relevancy in (0, 1).
    pub relevancy: f32,
    /// Its cosine similarity to the query, in [−1, 1].
    pub cosine: f32,
}

/// Embeddings of one kind: `rows` vectors of `dim` values each, row-major `[rows, dim]`.
#[derive(Debug, Clone, Copy)]
pub struct Embeddings<'a> {
    /// `[rows, dim]`.
    pub values: &'a [f32],
    /// Width of each vector.
    pub dim: usize,
}

impl<'a> Embeddings<'a> {
    /// `values` `[rows, dim]`, checked to hold whole rows.
    pub fn new(values: &'a [f32], dim: usize, what: &str) -> ModelsResult<Self> {
        if dim == 0 || !values.len().is_multiple_of(dim) {
            return Err(ModelsError::Input(format!(
                "{what}: {} values are not whole rows of {dim}",
                values.len()
            )));
        }
        Ok(Self { values, dim })
    }

    /// Number of vectors.
    pub fn rows(&self) -> usize {
        self.values.len() / self.dim
    }

    fn row(&self, i: usize) -> &'a [f32] {
        &self.values[i * self.dim..(i + 1) * self.dim]
    }
}

/// The `top_k` objects most relevant to `query` (`[E]`), `objects` being `[N, E]` with `ids` `[N]`
/// and `negatives` `[M, E]` (M ≥ 1, the canonical phrases' embeddings); `scale` as [`LERF_SCALE`].
/// Inputs need not be normalised; a zero or non-finite vector is an error.
pub fn rank_objects(
    ids: &[u32],
    objects: Embeddings,
    query: &[f32],
    negatives: Embeddings,
    scale: f32,
    top_k: usize,
) -> ModelsResult<Vec<RankedObject>> {
    let dim = objects.dim;
    if ids.len() != objects.rows() {
        return Err(ModelsError::Input(format!(
            "{} ids for {} object embeddings",
            ids.len(),
            objects.rows()
        )));
    }
    if query.len() != dim || negatives.dim != dim {
        return Err(ModelsError::Input(format!(
            "embedding widths differ: objects {dim}, query {}, negatives {}",
            query.len(),
            negatives.dim
        )));
    }
    if negatives.rows() == 0 {
        return Err(ModelsError::Input("relevancy needs at least one negative phrase".into()));
    }
    if !(scale.is_finite() && scale > 0.0) {
        return Err(ModelsError::Input(format!("the softmax scale must be positive, got {scale}")));
    }
    let query = normalised(query, "the query")?;
    let negatives: Vec<Vec<f32>> = (0..negatives.rows())
        .map(|j| normalised(negatives.row(j), &format!("negative phrase {j}")))
        .collect::<ModelsResult<_>>()?;
    let mut ranked = Vec::with_capacity(ids.len());
    for (i, &id) in ids.iter().enumerate() {
        let object = normalised(objects.row(i), &format!("object {id}"))?;
        let cosine = dot(&object, &query);
        let relevancy = negatives
            .iter()
            .map(|negative| logistic(scale * (cosine - dot(&object, negative))))
            .fold(f32::INFINITY, f32::min);
        ranked.push(RankedObject { id, relevancy, cosine });
    }
    ranked.sort_by(|a, b| b.relevancy.total_cmp(&a.relevancy).then(a.id.cmp(&b.id)));
    ranked.truncate(top_k);
    Ok(ranked)
}

/// `1 / (1 + e^{−x})` = `e^x / (e^x + 1)`, without overflow for large |x|.
fn logistic(x: f32) -> f32 {
    if x >= 0.0 {
        1.0 / (1.0 + (-x).exp())
    } else {
        let e = x.exp();
        e / (1.0 + e)
    }
}

fn dot(a: &[f32], b: &[f32]) -> f32 {
    a.iter().zip(b).map(|(x, y)| f64::from(*x) * f64::from(*y)).sum::<f64>() as f32
}

fn normalised(v: &[f32], what: &str) -> ModelsResult<Vec<f32>> {
    let norm = v.iter().map(|x| f64::from(*x) * f64::from(*x)).sum::<f64>().sqrt();
    if !(norm.is_finite() && norm > 0.0) {
        return Err(ModelsError::Input(format!(
            "{what}'s embedding has length {norm}: it cannot be compared"
        )));
    }
    Ok(v.iter().map(|x| (f64::from(*x) / norm) as f32).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sigmoid(x: f64) -> f32 {
        (1.0 / (1.0 + (-x).exp())) as f32
    }

    /// Axis-aligned unit vectors in 4 dimensions: e0 = "mug", e1 = "chair", e2, e3 = the negatives.
    fn axis(i: usize) -> Vec<f32> {
        let mut v = vec![0.0; 4];
        v[i] = 1.0;
        v
    }

    fn rank(
        ids: &[u32],
        objects: &[Vec<f32>],
        query: &[f32],
        negatives: &[Vec<f32>],
        k: usize,
    ) -> Vec<RankedObject> {
        let flat: Vec<f32> = objects.concat();
        let negs: Vec<f32> = negatives.concat();
        rank_objects(
            ids,
            Embeddings::new(&flat, query.len(), "objects").unwrap(),
            query,
            Embeddings::new(&negs, query.len(), "negatives").unwrap(),
            LERF_SCALE,
            k,
        )
        .unwrap()
    }

    #[test]
    fn the_object_along_the_query_wins_with_the_known_relevancy() {
        let objects = vec![axis(1), axis(0), vec![0.0, 0.0, 1.0, 0.0]];
        let ranked = rank(&[10, 20, 30], &objects, &axis(0), &[axis(2), axis(3)], 3);
        assert_eq!(ranked.iter().map(|r| r.id).collect::<Vec<_>>(), vec![20, 10, 30]);
        // id 20: cos to query 1, to both negatives 0 → σ(10)
        assert!((ranked[0].relevancy - sigmoid(10.0)).abs() < 1e-6, "{ranked:?}");
        assert!((ranked[0].cosine - 1.0).abs() < 1e-6);
        // id 10: 0 against 0 → exactly 1/2; id 30 lies on negative e2: σ(10·(0 − 1)) = σ(−10)
        assert!((ranked[1].relevancy - 0.5).abs() < 1e-6);
        assert!((ranked[2].relevancy - sigmoid(-10.0)).abs() < 1e-6);
    }

    #[test]
    fn negatives_demote_a_generic_object_with_a_higher_raw_cosine() {
        // object 1 is closer to the query than object 2 but also close to "stuff" (e2); object 2 is far
        // from every negative. Raw cosine ranks 3, 1, 2; relevancy ranks 2, 3, 1.
        let s = 0.5f32.sqrt();
        let generic = vec![0.8, 0.0, 0.6, 0.0]; // cos(query) 0.8, cos(e2) 0.6
        let specific = vec![s, s, 0.0, 0.0]; // cos(query) 0.707, cos(negatives) 0
        let c = (1.0f32 - 0.81).sqrt();
        let sharper = vec![0.9, 0.0, 0.0, c]; // cos(query) 0.9, cos(e3) 0.436
        let ranked = rank(&[1, 2, 3], &[generic, specific, sharper], &axis(0), &[axis(2), axis(3)], 3);
        assert_eq!(ranked.iter().map(|r| r.id).collect::<Vec<_>>(), vec![2, 3, 1]);
        let by_id = |id| *ranked.iter().find(|r| r.id == id).unwrap();
        assert!(by_id(1).cosine > by_id(2).cosine, "the raw cosine prefers the generic object");
        assert!((by_id(1).relevancy - sigmoid(10.0 * (0.8 - 0.6))).abs() < 1e-6);
        assert!((by_id(2).relevancy - sigmoid(10.0 * f64::from(s))).abs() < 1e-6);
        assert!((by_id(3).relevancy - sigmoid(10.0 * (0.9 - f64::from(c)))).abs() < 1e-5, "{ranked:?}");
    }

    #[test]
    fn the_minimum_over_negatives_decides() {
        // the same object against negatives [e2] and [e2, e3]: adding the closer e3 lowers the score
        let object = vec![0.8, 0.0, 0.0, 0.6];
        let one = rank(&[1], std::slice::from_ref(&object), &axis(0), &[axis(2)], 1)[0].relevancy;
        let two = rank(&[1], &[object], &axis(0), &[axis(2), axis(3)], 1)[0].relevancy;
        assert!((one - sigmoid(8.0)).abs() < 1e-6);
        assert!((two - sigmoid(10.0 * (0.8 - 0.6))).abs() < 1e-6);
    }

    #[test]
    fn ties_break_by_id_and_top_k_cuts() {
        // three equal objects (cos 0.42 to the query, 0.71 to e3: σ(−2.8)) below one orthogonal to
        // everything (exactly 1/2); the equal ones in id order whatever their input order
        let same = vec![0.3, 0.4, 0.0, 0.5];
        let objects = vec![same.clone(), axis(1), same.clone(), same];
        let ranked = rank(&[9, 1, 4, 7], &objects, &axis(0), &[axis(2), axis(3)], 10);
        assert_eq!(ranked.iter().map(|r| r.id).collect::<Vec<_>>(), vec![1, 4, 7, 9]);
        assert_eq!(ranked[1].relevancy, ranked[3].relevancy);
        let top2 = rank(&[9, 1, 4, 7], &[axis(1), axis(1), axis(1), axis(1)], &axis(0), &[axis(2)], 2);
        assert_eq!(top2.iter().map(|r| r.id).collect::<Vec<_>>(), vec![1, 4]);
        assert!(rank(&[9], &[axis(0)], &axis(0), &[axis(2)], 0).is_empty());
    }

    #[test]
    fn scale_of_the_inputs_does_not_matter() {
        let objects = vec![vec![3.0, 4.0, 0.0, 0.0], vec![0.0, 1.0, 1.0, 0.0]];
        let scaled: Vec<Vec<f32>> = objects.iter().map(|v| v.iter().map(|x| x * 7.5).collect()).collect();
        let query = vec![2.0, 0.0, 0.0, 0.0];
        let a = rank(&[1, 2], &objects, &query, &[axis(2)], 2);
        let b = rank(&[1, 2], &scaled, &axis(0), &[vec![0.0, 0.0, 9.0, 0.0]], 2);
        for (x, y) in a.iter().zip(&b) {
            assert_eq!(x.id, y.id);
            assert!((x.relevancy - y.relevancy).abs() < 1e-6 && (x.cosine - y.cosine).abs() < 1e-6);
        }
    }

    #[test]
    fn bad_inputs_are_errors() {
        let objects = [1.0, 0.0, 0.0, 0.0];
        let negs = [0.0, 0.0, 1.0, 0.0];
        let o = Embeddings::new(&objects, 4, "objects").unwrap();
        let n = Embeddings::new(&negs, 4, "negatives").unwrap();
        let err = |r: ModelsResult<Vec<RankedObject>>| r.unwrap_err().to_string();
        assert!(err(rank_objects(&[1, 2], o, &axis(0), n, LERF_SCALE, 1)).contains("2 ids for 1"));
        assert!(err(rank_objects(&[1], o, &[1.0, 0.0], n, LERF_SCALE, 1)).contains("widths differ"));
        assert!(err(rank_objects(&[1], o, &[0.0; 4], n, LERF_SCALE, 1)).contains("query"));
        let nan = [f32::NAN, 0.0, 0.0, 0.0];
        let bad = Embeddings::new(&nan, 4, "objects").unwrap();
        assert!(err(rank_objects(&[5], bad, &axis(0), n, LERF_SCALE, 1)).contains("object 5"));
        let none = Embeddings::new(&[], 4, "negatives").unwrap();
        assert!(err(rank_objects(&[1], o, &axis(0), none, LERF_SCALE, 1)).contains("negative"));
        assert!(err(rank_objects(&[1], o, &axis(0), n, 0.0, 1)).contains("scale"));
        assert!(Embeddings::new(&[1.0; 5], 4, "objects").is_err());
    }
}

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
//! Objects are ranked by relevancy, highest first (by the margin under the σ, so relevancies that
//! round to the same `f32` near 1 keep their order); equal margins by id, lowest first. The
//! arithmetic is sequential, so the ranking does not depend on the thread count. [`best_names`]
//! scores a list of names the same way and gives each object the name it is most relevant to.

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
///
/// Ranked by relevancy, highest first. As `min_j σ(s·(c − n_j)) = σ(s·min_j (c − n_j))`, the order is
/// that of the margin `min_j (φ·q − φ·n_j)`, computed in `f64`: relevancies that round to the same
/// `f32` (σ saturates at 1 for margins above ≈ 1.7) keep the order of their margins; equal margins go
/// by id, lowest first.
pub fn rank_objects(
    ids: &[u32],
    objects: Embeddings,
    query: &[f32],
    negatives: Embeddings,
    scale: f32,
    top_k: usize,
) -> ModelsResult<Vec<RankedObject>> {
    let scorer = Scorer::new(ids, objects, negatives, scale)?;
    let query = scorer.query(query, "the query")?;
    let mut scored = Vec::with_capacity(ids.len());
    for (i, &id) in ids.iter().enumerate() {
        let object = scorer.object(i)?;
        let (margin, cosine) = scorer.margin(&object, &query);
        scored
            .push((margin, RankedObject { id, relevancy: scorer.relevancy(margin), cosine: cosine as f32 }));
    }
    scored.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.id.cmp(&b.1.id)));
    Ok(scored.into_iter().take(top_k).map(|(_, r)| r).collect())
}

/// One object's best name among a list (see [`best_names`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NamedObject {
    /// The object's id.
    pub id: u32,
    /// Index of its best name in the list.
    pub name: usize,
    /// Its relevancy to that name, in (0, 1).
    pub relevancy: f32,
}

/// For every object (`objects` `[N, E]`, `ids` `[N]`), the name it is most relevant to, each of
/// `names` (`[K, E]`, K ≥ 1, the names' text embeddings) scored as [`rank_objects`] scores a query
/// against `negatives` (`[M, E]`): the largest margin wins, the first name in the list on equal
/// margins. In the objects' order.
pub fn best_names(
    ids: &[u32],
    objects: Embeddings,
    names: Embeddings,
    negatives: Embeddings,
    scale: f32,
) -> ModelsResult<Vec<NamedObject>> {
    let scorer = Scorer::new(ids, objects, negatives, scale)?;
    if names.dim != objects.dim || names.rows() == 0 {
        return Err(ModelsError::Input(format!(
            "{} names of width {} for objects of width {}: at least one name of the objects' width is needed",
            names.rows(),
            names.dim,
            objects.dim
        )));
    }
    let names: Vec<Vec<f32>> = (0..names.rows())
        .map(|k| scorer.query(names.row(k), &format!("name {k}")))
        .collect::<ModelsResult<_>>()?;
    let mut named = Vec::with_capacity(ids.len());
    for (i, &id) in ids.iter().enumerate() {
        let object = scorer.object(i)?;
        let mut best = (0, f64::NEG_INFINITY);
        for (k, name) in names.iter().enumerate() {
            let (margin, _) = scorer.margin(&object, name);
            if margin > best.1 {
                best = (k, margin);
            }
        }
        named.push(NamedObject { id, name: best.0, relevancy: scorer.relevancy(best.1) });
    }
    Ok(named)
}

/// The checked inputs shared by [`rank_objects`] and [`best_names`], with the negatives normalised.
struct Scorer<'a> {
    ids: &'a [u32],
    objects: Embeddings<'a>,
    negatives: Vec<Vec<f32>>,
    scale: f32,
}

impl<'a> Scorer<'a> {
    fn new(ids: &'a [u32], objects: Embeddings<'a>, negatives: Embeddings, scale: f32) -> ModelsResult<Self> {
        if ids.len() != objects.rows() {
            return Err(ModelsError::Input(format!(
                "{} ids for {} object embeddings",
                ids.len(),
                objects.rows()
            )));
        }
        if negatives.dim != objects.dim {
            return Err(ModelsError::Input(format!(
                "embedding widths differ: objects {}, negatives {}",
                objects.dim, negatives.dim
            )));
        }
        if negatives.rows() == 0 {
            return Err(ModelsError::Input("relevancy needs at least one negative phrase".into()));
        }
        if !(scale.is_finite() && scale > 0.0) {
            return Err(ModelsError::Input(format!("the softmax scale must be positive, got {scale}")));
        }
        let negatives = (0..negatives.rows())
            .map(|j| normalised(negatives.row(j), &format!("negative phrase {j}")))
            .collect::<ModelsResult<_>>()?;
        Ok(Self { ids, objects, negatives, scale })
    }

    /// A text embedding `[E]` checked against the objects' width and normalised.
    fn query(&self, query: &[f32], what: &str) -> ModelsResult<Vec<f32>> {
        if query.len() != self.objects.dim {
            return Err(ModelsError::Input(format!(
                "embedding widths differ: objects {}, {what} {}",
                self.objects.dim,
                query.len()
            )));
        }
        normalised(query, what)
    }

    /// Object `i`, normalised.
    fn object(&self, i: usize) -> ModelsResult<Vec<f32>> {
        normalised(self.objects.row(i), &format!("object {}", self.ids[i]))
    }

    /// `(min_j (φ·q − φ·n_j), φ·q)` of a normalised object and query.
    fn margin(&self, object: &[f32], query: &[f32]) -> (f64, f64) {
        let cosine = dot(object, query);
        let margin = self.negatives.iter().map(|n| cosine - dot(object, n)).fold(f64::INFINITY, f64::min);
        (margin, cosine)
    }

    /// `σ(s · margin)`.
    fn relevancy(&self, margin: f64) -> f32 {
        logistic(f64::from(self.scale) * margin) as f32
    }
}

/// `1 / (1 + e^{−x})` = `e^x / (e^x + 1)`, without overflow for large |x|.
fn logistic(x: f64) -> f64 {
    if x >= 0.0 {
        1.0 / (1.0 + (-x).exp())
    } else {
        let e = x.exp();
        e / (1.0 + e)
    }
}

fn dot(a: &[f32], b: &[f32]) -> f64 {
    a.iter().zip(b).map(|(x, y)| f64::from(*x) * f64::from(*y)).sum::<f64>()
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
    fn saturated_relevancies_keep_the_order_of_their_margins() {
        // the query e0 against the negative −e0: margin = 2·cos. Object 7 along the query (margin 2)
        // and object 5 at cos 0.95 (margin 1.9): σ(20) and σ(19) both round to 1.0 in f32, yet 7
        // ranks first; equal margins go to the lower id
        let minus = vec![-1.0, 0.0, 0.0, 0.0];
        let c = (1.0f32 - 0.95 * 0.95).sqrt();
        let ranked =
            rank(&[5, 7], &[vec![0.95, c, 0.0, 0.0], axis(0)], &axis(0), std::slice::from_ref(&minus), 2);
        assert_eq!(ranked.iter().map(|r| r.relevancy).collect::<Vec<_>>(), vec![1.0, 1.0], "{ranked:?}");
        assert_eq!(ranked.iter().map(|r| r.id).collect::<Vec<_>>(), vec![7, 5], "{ranked:?}");
        let tied = rank(&[9, 3], &[axis(0), axis(0)], &axis(0), &[minus], 2);
        assert_eq!(tied.iter().map(|r| r.id).collect::<Vec<_>>(), vec![3, 9]);
    }

    #[test]
    fn top_k_is_a_prefix_of_the_whole_ranking() {
        let objects: Vec<Vec<f32>> = (0..9)
            .map(|i| {
                let t = i as f32 * 0.7;
                vec![t.cos(), t.sin(), 0.3 * (i % 3) as f32, 0.2]
            })
            .collect();
        let ids: Vec<u32> = (0..9).map(|i| 100 - 3 * i).collect();
        let all = rank(&ids, &objects, &axis(0), &[axis(2), axis(3)], usize::MAX);
        assert_eq!(all.len(), 9);
        for k in 0..=10 {
            assert_eq!(rank(&ids, &objects, &axis(0), &[axis(2), axis(3)], k), all[..k.min(9)], "k = {k}");
        }
        // and the order of the input rows does not matter
        let mut rows: Vec<(u32, Vec<f32>)> = ids.iter().copied().zip(objects.clone()).collect();
        rows.reverse();
        let (rev_ids, rev_objects): (Vec<u32>, Vec<Vec<f32>>) = rows.into_iter().unzip();
        assert_eq!(rank(&rev_ids, &rev_objects, &axis(0), &[axis(2), axis(3)], usize::MAX), all);
    }

    fn names(
        ids: &[u32],
        objects: &[Vec<f32>],
        names: &[Vec<f32>],
        negatives: &[Vec<f32>],
    ) -> Vec<NamedObject> {
        let (flat, text, negs) = (objects.concat(), names.concat(), negatives.concat());
        best_names(
            ids,
            Embeddings::new(&flat, 4, "objects").unwrap(),
            Embeddings::new(&text, 4, "names").unwrap(),
            Embeddings::new(&negs, 4, "negatives").unwrap(),
            LERF_SCALE,
        )
        .unwrap()
    }

    #[test]
    fn each_object_gets_the_name_it_is_most_relevant_to() {
        // names: e0 "mug", e1 "chair", (e0 + e3)/√2 "cup"; negative e2
        let s = 0.5f32.sqrt();
        let list = vec![axis(0), axis(1), vec![s, 0.0, 0.0, s]];
        let objects = vec![axis(1), vec![0.6, 0.0, 0.0, 0.8], axis(0), vec![0.0, 0.0, 1.0, 0.0]];
        let named = names(&[4, 8, 15, 16], &objects, &list, &[axis(2)]);
        assert_eq!(
            named.iter().map(|n| (n.id, n.name)).collect::<Vec<_>>(),
            vec![(4, 1), (8, 2), (15, 0), (16, 0)]
        );
        // object 8: cos(cup) = (0.6 + 0.8)/√2 = 0.99, cos(e2) = 0 → σ(9.9)
        assert!((named[1].relevancy - sigmoid(10.0 * 1.4 / 2f64.sqrt())).abs() < 1e-6, "{named:?}");
        // object 16 lies on the negative: every name has margin −1, the first name wins the tie
        assert!((named[3].relevancy - sigmoid(-10.0)).abs() < 1e-6);
        // each relevancy is the highest that the names, as queries, give the object
        for (i, n) in named.iter().enumerate() {
            let one = std::slice::from_ref(&objects[i]);
            let best =
                list.iter().map(|q| rank(&[n.id], one, q, &[axis(2)], 1)[0].relevancy).fold(0.0, f32::max);
            assert_eq!(n.relevancy, best, "{n:?}");
        }
    }

    #[test]
    fn names_need_at_least_one_name_of_the_right_width() {
        let objects = [1.0, 0.0, 0.0, 0.0];
        let negs = [0.0, 0.0, 1.0, 0.0];
        let o = Embeddings::new(&objects, 4, "objects").unwrap();
        let n = Embeddings::new(&negs, 4, "negatives").unwrap();
        let none = Embeddings::new(&[], 4, "names").unwrap();
        let err = best_names(&[1], o, none, n, LERF_SCALE).unwrap_err().to_string();
        assert!(err.contains("at least one name"), "{err}");
        let narrow = Embeddings::new(&[1.0, 0.0], 2, "names").unwrap();
        assert!(best_names(&[1], o, narrow, n, LERF_SCALE).is_err());
        let zero = Embeddings::new(&[0.0; 4], 4, "names").unwrap();
        assert!(best_names(&[1], o, zero, n, LERF_SCALE).unwrap_err().to_string().contains("name 0"));
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

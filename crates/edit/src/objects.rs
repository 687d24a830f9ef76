//! The object table of a labelled PLY: per object id, how many Gaussians, where, which colour,
//! and (given label maps) in how many views it is seen.

use crate::error::EditError;
use crate::select::object_ids;
use serde::{Deserialize, Serialize};
use splatseg_scene::{Gaussians, Plane};

/// One object of a labelled PLY.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ObjectInfo {
    /// Object id (as in `object_id` and in the label maps).
    pub id: i32,
    /// Number of Gaussians carrying it.
    pub gaussian_count: u64,
    /// Smallest x, y, z of their centres (world units).
    pub bbox_min: [f32; 3],
    /// Largest x, y, z of their centres.
    pub bbox_max: [f32; 3],
    /// Its palette colour.
    pub colour: [u8; 3],
    /// Number of label maps showing it (None when no label maps were given).
    pub views_seen: Option<usize>,
    /// The name `splatseg apply` gave it from the edits' `rename` (none: left out).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
}

/// All objects of a labelled PLY.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ObjectTable {
    /// Objects with id ≥ 0, by id.
    pub objects: Vec<ObjectInfo>,
    /// Gaussians with no object (id < 0).
    pub unlabelled_gaussians: u64,
    /// All Gaussians.
    pub total_gaussians: u64,
}

/// Lists the objects of `g`. Fails without object ids.
pub fn objects(g: &Gaussians) -> Result<ObjectTable, EditError> {
    let ids = object_ids(g)?;
    let mut order: Vec<usize> = (0..ids.len()).filter(|&i| ids[i] >= 0).collect();
    order.sort_by_key(|&i| ids[i]);
    let mut objects: Vec<ObjectInfo> = Vec::new();
    for i in order {
        let (id, p) = (ids[i], g.means[i]);
        match objects.last_mut() {
            Some(o) if o.id == id => {
                o.gaussian_count += 1;
                o.bbox_min = [0, 1, 2].map(|k| o.bbox_min[k].min(p[k]));
                o.bbox_max = [0, 1, 2].map(|k| o.bbox_max[k].max(p[k]));
            }
            _ => objects.push(ObjectInfo {
                id,
                gaussian_count: 1,
                bbox_min: p,
                bbox_max: p,
                colour: splatseg_scene::labels::colour_of_id(id.max(0) as u32),
                views_seen: None,
                name: None,
            }),
        }
    }
    let labelled: u64 = objects.iter().map(|o| o.gaussian_count).sum();
    Ok(ObjectTable {
        objects,
        unlabelled_gaussians: g.len() as u64 - labelled,
        total_gaussians: g.len() as u64,
    })
}

/// Distinct non-zero ids of a label map (`[H, W]`), sorted.
pub fn ids_in_label_map(labels: &Plane<u32>) -> Vec<u32> {
    let mut ids: Vec<u32> = Vec::new();
    let mut last = 0u32;
    for &v in &labels.data {
        if v != 0 && v != last {
            ids.push(v);
        }
        last = v;
    }
    ids.sort_unstable();
    ids.dedup();
    ids
}

/// The file `splatseg apply` writes beside `gaussians.ply`: the [`ObjectTable`] of the edited
/// objects, with their names.
pub const OBJECTS_FILE: &str = "objects.json";

/// The names given by `splatseg apply` to the objects of the PLY at `ply`, read from
/// [`OBJECTS_FILE`] beside it (id → name; empty when there is no such file).
pub fn names_beside(ply: &std::path::Path) -> Result<std::collections::BTreeMap<i32, String>, EditError> {
    let path = ply.parent().unwrap_or(std::path::Path::new(".")).join(OBJECTS_FILE);
    let Ok(text) = std::fs::read_to_string(&path) else { return Ok(Default::default()) };
    let table: ObjectTable = serde_json::from_str(&text).map_err(|e| EditError::EditsFile {
        message: format!("not the object table `splatseg apply` writes ({e})"),
        path: path.clone(),
    })?;
    Ok(table.objects.into_iter().filter_map(|o| o.name.map(|n| (o.id, n))).collect())
}

impl ObjectTable {
    /// Sets each object's name from `names` (id → name).
    pub fn set_names(&mut self, names: &std::collections::BTreeMap<i32, String>) {
        for o in &mut self.objects {
            o.name = names.get(&o.id).cloned();
        }
    }

    /// Sets `views_seen` of every object from the ids present in each view (as returned by
    /// [`ids_in_label_map`], one list per view).
    pub fn set_views_seen(&mut self, ids_per_view: &[Vec<u32>]) {
        for o in &mut self.objects {
            let id = o.id as u32;
            o.views_seen = Some(ids_per_view.iter().filter(|ids| ids.binary_search(&id).is_ok()).count());
        }
    }

    /// A Markdown table of the objects.
    pub fn to_markdown(&self) -> String {
        use std::fmt::Write;
        let named = self.objects.iter().any(|o| o.name.is_some());
        let mut out = String::from("| id | Gaussians | bbox min | bbox max | colour | views |");
        out += if named {
            " name |\n| ---: | ---: | --- | --- | --- | ---: | --- |\n"
        } else {
            "\n| ---: | ---: | --- | --- | --- | ---: |\n"
        };
        let v3 = |v: [f32; 3]| format!("{:.3}, {:.3}, {:.3}", v[0], v[1], v[2]);
        for o in &self.objects {
            let [r, g, b] = o.colour;
            let views = o.views_seen.map_or_else(|| "–".to_string(), |v| v.to_string());
            let name = if named { format!(" {} |", o.name.as_deref().unwrap_or("")) } else { String::new() };
            let _ = writeln!(
                out,
                "| {} | {} | {} | {} | #{r:02x}{g:02x}{b:02x} | {views} |{name}",
                o.id,
                o.gaussian_count,
                v3(o.bbox_min),
                v3(o.bbox_max)
            );
        }
        let _ = writeln!(
            out,
            "\n{} objects, {} of {} Gaussians unlabelled.",
            self.objects.len(),
            self.unlabelled_gaussians,
            self.total_gaussians
        );
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::labelled_gaussians;

    #[test]
    fn counts_boxes_and_views() {
        let mut g = labelled_gaussians(&[4, -1, 2, 4, 4]);
        g.means = vec![[0.0, 1.0, 2.0], [9.0, 9.0, 9.0], [5.0, 5.0, 5.0], [-1.0, 3.0, 0.5], [0.5, -2.0, 1.0]];
        let mut t = objects(&g).unwrap();
        assert_eq!((t.total_gaussians, t.unlabelled_gaussians), (5, 1));
        assert_eq!(
            t.objects.iter().map(|o| (o.id, o.gaussian_count)).collect::<Vec<_>>(),
            vec![(2, 1), (4, 3)]
        );
        assert_eq!(t.objects[1].bbox_min, [-1.0, -2.0, 0.5]);
        assert_eq!(t.objects[1].bbox_max, [0.5, 3.0, 2.0]);
        assert_eq!(t.objects[0].colour, splatseg_scene::labels::colour_of_id(2));
        let view_a = Plane::from_vec(3, 1, vec![4, 0, 4]).unwrap();
        let view_b = Plane::from_vec(3, 1, vec![2, 4, 7]).unwrap();
        assert_eq!(ids_in_label_map(&view_b), vec![2, 4, 7]);
        t.set_views_seen(&[ids_in_label_map(&view_a), ids_in_label_map(&view_b)]);
        assert_eq!(t.objects[0].views_seen, Some(1));
        assert_eq!(t.objects[1].views_seen, Some(2));
        assert!(t.to_markdown().contains("| 4 | 3 | -1.000, -2.000, 0.500 | 0.500, 3.000, 2.000 |"));
        assert!(!t.to_markdown().contains("name"), "no name column without names");
        t.set_names(&[(4, "lamp".to_string())].into());
        let md = t.to_markdown();
        assert!(
            md.contains("| views | name |") && md.contains("| 2 | lamp |") && md.contains("| 1 |  |"),
            "{md}"
        );
    }
}

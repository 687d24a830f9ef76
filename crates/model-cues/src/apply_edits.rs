//! `splatseg apply` on a run made with `--clip`: the edits applied
//! ([`splatseg_pipeline::apply::apply_edits`]), then the objects embedded again.
//!
//! The object embeddings (`OUT/objects/`) describe the objects of the outputs they were made from,
//! so committing the edited outputs removes them (ids merged away, new ids of splits). When the run
//! had them, the edited objects are embedded again, with the checkpoint the index names, from the
//! edited label maps and the run's scene ([`crate::clip_objects::embed_objects`]): `find`,
//! `extract`/`remove --query` and the viewer's search then rank the edited objects. When that
//! fails (the checkpoint moved), the edits stay applied and the failure is returned as a warning
//! saying how to embed them again.

use crate::clip_objects::{embed_objects, ObjectEmbeddingRequest, ObjectEmbeddingSummary, OBJECTS_DIR};
use crate::object_index::ObjectIndex;
use splatseg_pipeline::apply::ApplySummary;
use splatseg_pipeline::RunOptions;
use std::path::Path;

/// What [`apply_edits`] did.
#[derive(Debug)]
pub struct AppliedEdits {
    /// The edits applied.
    pub applied: ApplySummary,
    /// The edited objects embedded again (`None`: the run had no object embeddings).
    pub embedded: Option<ObjectEmbeddingSummary>,
    /// Why the edited objects could not be embedded again, and what to do.
    pub warning: Option<String>,
}

impl AppliedEdits {
    /// What `splatseg apply` prints.
    pub fn to_text(&self, out: &Path) -> String {
        let mut text = self.applied.to_text(out);
        if let Some(embedded) = &self.embedded {
            text.push_str(&embedded.to_text());
        }
        text
    }
}

/// Applies `OUT/edits.json` to the run in `out`, then embeds the edited objects again when the run
/// had object embeddings (module docs).
pub fn apply_edits(out: &Path, options: RunOptions, show_progress: bool) -> crate::Result<AppliedEdits> {
    let index_path = out.join(OBJECTS_DIR).join(crate::clip_objects::INDEX_FILE);
    let index = index_path.is_file().then(|| ObjectIndex::read(&index_path));
    let applied = splatseg_pipeline::apply::apply_edits(out, options)?;
    let Some(index) = index else { return Ok(AppliedEdits { applied, embedded: None, warning: None }) };
    let embedded = index.and_then(|index| {
        let request = ObjectEmbeddingRequest {
            scene: splatseg_pipeline::apply::run_scene_folder(out)?,
            out: out.to_path_buf(),
            clip: index.checkpoint,
            show_progress,
        };
        embed_objects(&request)
    });
    Ok(match embedded {
        Ok(summary) => AppliedEdits { applied, embedded: Some(summary), warning: None },
        Err(e) => AppliedEdits {
            applied,
            embedded: None,
            warning: Some(format!(
                "the edits are applied, but the edited objects could not be embedded again ({}): `find` and \
                 queries need `splatseg run` with the run's arguments and --clip CKPT on {} (the run is up to \
                 date: only the objects are embedded, the edits stay)",
                e.report(),
                out.display()
            )),
        },
    })
}

//! Depth Anything V2 head names: the original release (`depth_head.projects.0`, `scratch.refinenet4`, ...)
//! mapped onto the Hugging Face layout (`neck.reassemble_stage.layers.0.projection`, `neck.fusion_stage.layers.0`,
//! `head.conv1`, ...), which the model uses.

/// The Hugging Face name of an original head tensor, `None` for tensors that are not part of the head.
pub fn original_to_hf(name: &str) -> Option<String> {
    let rest = name.strip_prefix("depth_head.")?;
    if let Some(r) = rest.strip_prefix("projects.") {
        let (i, field) = r.split_once('.')?;
        return Some(format!("neck.reassemble_stage.layers.{i}.projection.{field}"));
    }
    if let Some(r) = rest.strip_prefix("resize_layers.") {
        let (i, field) = r.split_once('.')?;
        return Some(format!("neck.reassemble_stage.layers.{i}.resize.{field}"));
    }
    let r = rest.strip_prefix("scratch.")?;
    if let Some(r) = r.strip_prefix("layer") {
        // layer{k}_rn.weight
        let (k, field) = r.split_once("_rn.")?;
        let k: usize = k.parse().ok()?;
        return Some(format!("neck.convs.{}.{field}", k.checked_sub(1)?));
    }
    if let Some(r) = r.strip_prefix("refinenet") {
        let (k, field) = r.split_once('.')?;
        let k: usize = k.parse().ok()?;
        let layer = 4usize.checked_sub(k)?;
        let mapped = if let Some(f) = field.strip_prefix("out_conv.") {
            format!("projection.{f}")
        } else {
            let (unit, conv) = field.split_once('.')?;
            let unit = match unit {
                "resConfUnit1" => "residual_layer1",
                "resConfUnit2" => "residual_layer2",
                _ => return None,
            };
            let (conv, f) = conv.split_once('.')?;
            let conv = match conv {
                "conv1" => "convolution1",
                "conv2" => "convolution2",
                _ => return None,
            };
            format!("{unit}.{conv}.{f}")
        };
        return Some(format!("neck.fusion_stage.layers.{layer}.{mapped}"));
    }
    let head = [
        ("output_conv1.", "head.conv1."),
        ("output_conv2.0.", "head.conv2."),
        ("output_conv2.2.", "head.conv3."),
    ];
    head.iter().find_map(|(from, to)| r.strip_prefix(from).map(|f| format!("{to}{f}")))
}

#[cfg(test)]
mod tests {
    use super::original_to_hf;

    #[test]
    fn maps_every_kind_of_head_tensor() {
        let cases = [
            ("depth_head.projects.2.weight", "neck.reassemble_stage.layers.2.projection.weight"),
            ("depth_head.resize_layers.3.bias", "neck.reassemble_stage.layers.3.resize.bias"),
            ("depth_head.scratch.layer1_rn.weight", "neck.convs.0.weight"),
            ("depth_head.scratch.refinenet4.out_conv.weight", "neck.fusion_stage.layers.0.projection.weight"),
            (
                "depth_head.scratch.refinenet1.resConfUnit2.conv1.bias",
                "neck.fusion_stage.layers.3.residual_layer2.convolution1.bias",
            ),
            ("depth_head.scratch.output_conv2.2.weight", "head.conv3.weight"),
        ];
        for (from, to) in cases {
            assert_eq!(original_to_hf(from).as_deref(), Some(to), "{from}");
        }
        assert_eq!(original_to_hf("pretrained.blocks.0.norm1.weight"), None);
    }
}

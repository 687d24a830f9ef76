//! Named tensors read from a checkpoint (`.safetensors` or a PyTorch `.pth`/`.pt`/`.bin` pickle), with
//! errors that name the file, the tensor and the shapes.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use candle_core::{DType, Device, Tensor};

use crate::conv::Conv2d;
use crate::error::{ModelKind, ModelsError, ModelsResult};

/// Tensors of one checkpoint, all converted to f32 on the CPU.
#[derive(Debug, Clone)]
pub struct Weights {
    tensors: HashMap<String, Tensor>,
    path: PathBuf,
    kind: ModelKind,
    /// Prefix removed by [`Weights::sub`], put back in messages.
    prefix: String,
}

impl Weights {
    /// Reads a checkpoint file: safetensors by content, otherwise a PyTorch pickle (state dict, or a dict
    /// holding one under `model` / `state_dict`).
    pub fn load(path: &Path, kind: ModelKind) -> ModelsResult<Self> {
        let unreadable = |reason: String| ModelsError::Unreadable { kind, reason, path: path.to_path_buf() };
        crate::checkpoint::refuse_special_file(path, kind)?;
        let mut magic = [0u8; 8];
        {
            use std::io::Read;
            let mut file = std::fs::File::open(path).map_err(|e| unreadable(e.to_string()))?;
            let _ = file.read(&mut magic).map_err(|e| unreadable(e.to_string()))?;
        }
        let is_zip_or_pickle = magic.starts_with(b"PK") || magic[0] == 0x80;
        let raw: Vec<(String, Tensor)> = if is_zip_or_pickle {
            // a plain state dict, or one nested under `model` / `state_dict` (training checkpoints)
            let mut found = candle_core::pickle::read_all(path);
            for key in ["model", "state_dict"] {
                if matches!(&found, Ok(t) if !t.is_empty()) {
                    break;
                }
                if let Ok(nested) = candle_core::pickle::read_all_with_key(path, Some(key)) {
                    if !nested.is_empty() {
                        found = Ok(nested);
                    }
                }
            }
            found.map_err(|e| unreadable(e.to_string()))?
        } else {
            candle_core::safetensors::load(path, &Device::Cpu)
                .map_err(|e| unreadable(e.to_string()))?
                .into_iter()
                .collect()
        };
        if raw.is_empty() {
            return Err(unreadable("it holds no tensors".into()));
        }
        let mut tensors = HashMap::with_capacity(raw.len());
        for (name, tensor) in raw {
            let tensor = if tensor.dtype() == DType::F32 { tensor } else { tensor.to_dtype(DType::F32)? };
            tensors.insert(name, tensor);
        }
        Ok(Self { tensors, path: path.to_path_buf(), kind, prefix: String::new() })
    }

    /// Wraps tensors already in memory (`path` is only used in messages).
    pub fn from_tensors(tensors: HashMap<String, Tensor>, path: &Path, kind: ModelKind) -> Self {
        Self { tensors, path: path.to_path_buf(), kind, prefix: String::new() }
    }

    /// Refuses weights holding a NaN or ±Inf: the error names the first such tensor (by name), how many
    /// of its values are not finite, and the file.
    pub fn check_finite(&self) -> ModelsResult<()> {
        for name in self.names() {
            let values = self.tensors[name].flatten_all()?.to_vec1::<f32>()?;
            let bad = values.iter().filter(|v| !v.is_finite()).count();
            if bad > 0 {
                return Err(ModelsError::NonFinite {
                    kind: self.kind,
                    name: format!("{}{name}", self.prefix),
                    count: bad,
                    total: values.len(),
                    path: self.path.clone(),
                });
            }
        }
        Ok(())
    }

    /// The file the tensors came from.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The model the file is meant for.
    pub fn kind(&self) -> ModelKind {
        self.kind
    }

    /// Whether a tensor exists.
    pub fn contains(&self, name: &str) -> bool {
        self.tensors.contains_key(name)
    }

    /// Shape of a tensor, if present.
    pub fn shape_of(&self, name: &str) -> Option<Vec<usize>> {
        self.tensors.get(name).map(|t| t.dims().to_vec())
    }

    /// All tensor names, sorted.
    pub fn names(&self) -> Vec<&str> {
        let mut names: Vec<&str> = self.tensors.keys().map(String::as_str).collect();
        names.sort_unstable();
        names
    }

    /// The tensor `name`, checked to have exactly `shape`.
    pub fn get(&self, name: &str, shape: &[usize]) -> ModelsResult<Tensor> {
        let tensor = self.tensors.get(name).ok_or_else(|| self.missing(name, shape))?;
        if tensor.dims() != shape {
            return Err(ModelsError::ShapeMismatch {
                kind: self.kind,
                name: format!("{}{name}", self.prefix),
                expected: shape.to_vec(),
                found: tensor.dims().to_vec(),
                path: self.path.clone(),
            });
        }
        Ok(tensor.clone())
    }

    /// The tensor `name` with whatever shape it has (used to infer a configuration).
    pub fn get_any(&self, name: &str) -> ModelsResult<Tensor> {
        self.tensors.get(name).cloned().ok_or_else(|| self.missing(name, &[]))
    }

    /// The "tensor missing" error for `name`.
    pub fn missing(&self, name: &str, expected: &[usize]) -> ModelsError {
        ModelsError::MissingTensor {
            kind: self.kind,
            name: format!("{}{name}", self.prefix),
            expected: expected.to_vec(),
            path: self.path.clone(),
        }
    }

    /// Removes and returns a tensor.
    pub fn take(&mut self, name: &str) -> Option<Tensor> {
        self.tensors.remove(name)
    }

    /// Inserts (or replaces) a tensor.
    pub fn insert(&mut self, name: String, tensor: Tensor) {
        self.tensors.insert(name, tensor);
    }

    /// The tensors whose names start with `prefix`, with the prefix removed.
    pub fn sub(&self, prefix: &str) -> Weights {
        let tensors = self
            .tensors
            .iter()
            .filter_map(|(name, t)| name.strip_prefix(prefix).map(|rest| (rest.to_string(), t.clone())))
            .collect();
        Weights {
            tensors,
            path: self.path.clone(),
            kind: self.kind,
            prefix: format!("{}{prefix}", self.prefix),
        }
    }

    /// Renames every tensor with `rename` (names it maps to `None` are dropped).
    pub fn renamed(self, mut rename: impl FnMut(&str) -> Option<String>) -> Weights {
        let tensors = self
            .tensors
            .into_iter()
            .filter_map(|(name, t)| rename(&name).map(|new_name| (new_name, t)))
            .collect();
        Weights { tensors, path: self.path, kind: self.kind, prefix: self.prefix }
    }

    /// A linear layer `weight: [out, in]`, `bias: [out]` under `prefix`.
    pub fn linear(&self, prefix: &str, in_dim: usize, out_dim: usize) -> ModelsResult<candle_nn::Linear> {
        let weight = self.get(&format!("{prefix}.weight"), &[out_dim, in_dim])?;
        let bias = self.get(&format!("{prefix}.bias"), &[out_dim])?;
        Ok(candle_nn::Linear::new(weight, Some(bias)))
    }

    /// A layer norm over `dim` channels under `prefix`.
    pub fn layer_norm(&self, prefix: &str, dim: usize, eps: f64) -> ModelsResult<candle_nn::LayerNorm> {
        let weight = self.get(&format!("{prefix}.weight"), &[dim])?;
        let bias = self.get(&format!("{prefix}.bias"), &[dim])?;
        Ok(candle_nn::LayerNorm::new(weight, bias, eps))
    }

    /// A 2D convolution `weight: [out, in, k, k]` (+ `bias: [out]` when `spec.bias`).
    pub fn conv2d(&self, prefix: &str, spec: ConvSpec) -> ModelsResult<Conv2d> {
        let weight = self.get(
            &format!("{prefix}.weight"),
            &[spec.out_channels, spec.in_channels, spec.kernel, spec.kernel],
        )?;
        let bias =
            if spec.bias { Some(self.get(&format!("{prefix}.bias"), &[spec.out_channels])?) } else { None };
        Conv2d::new(&weight, bias, spec.stride, spec.padding)
    }
}

/// Shape and geometry of a square-kernel 2D convolution.
#[derive(Debug, Clone, Copy)]
pub struct ConvSpec {
    /// Input channels.
    pub in_channels: usize,
    /// Output channels.
    pub out_channels: usize,
    /// Kernel side.
    pub kernel: usize,
    /// Stride.
    pub stride: usize,
    /// Zero padding on each side.
    pub padding: usize,
    /// Whether the layer has a bias.
    pub bias: bool,
}

impl ConvSpec {
    /// A `kernel`×`kernel` convolution with stride 1, "same" padding and a bias.
    pub fn same(in_channels: usize, out_channels: usize, kernel: usize) -> Self {
        Self { in_channels, out_channels, kernel, stride: 1, padding: kernel / 2, bias: true }
    }
}

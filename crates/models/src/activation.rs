//! Element-wise activations run in parallel and vectorised (candle-core's CPU unary ops use one thread
//! and a scalar `erf`).

use candle_core::{CpuStorage, CustomOp1, Layout, Shape, Tensor};
use rayon::prelude::*;

use crate::error::ModelsResult;
use crate::kernels;

/// Elements per parallel chunk.
const CHUNK: usize = 1 << 14;

/// The exact (erf) GELU, `x · (1 + erf(x / √2)) / 2`, as PyTorch's default `nn.GELU()`, with `erf` as
/// PyTorch's vectorised CPU kernel computes it ([`kernels::erf`]); any shape, f32.
pub fn gelu_erf(x: &Tensor) -> ModelsResult<Tensor> {
    Ok(x.contiguous()?.apply_op1_no_bwd(&GeluErf)?)
}

struct GeluErf;

impl CustomOp1 for GeluErf {
    fn name(&self) -> &'static str {
        "parallel-gelu-erf"
    }

    fn cpu_fwd(&self, storage: &CpuStorage, layout: &Layout) -> candle_core::Result<(CpuStorage, Shape)> {
        let input = match (storage, layout.contiguous_offsets()) {
            (CpuStorage::F32(data), Some((start, end))) => &data[start..end],
            _ => candle_core::bail!("gelu_erf needs a contiguous f32 tensor"),
        };
        let mut out = vec![0f32; input.len()];
        out.par_chunks_mut(CHUNK).zip(input.par_chunks(CHUNK)).for_each(|(out, input)| {
            out.copy_from_slice(input);
            kernels::gelu_in_place(out);
        });
        Ok((CpuStorage::F32(out), layout.shape().clone()))
    }
}

#[cfg(test)]
mod tests {
    use candle_core::Device;

    use super::*;

    #[test]
    fn matches_the_exact_gelu_in_any_layout() {
        let x = Tensor::randn(0f32, 3.0, (3, 50_001), &Device::Cpu).unwrap();
        let ours = gelu_erf(&x).unwrap().flatten_all().unwrap().to_vec1::<f32>().unwrap();
        // candle's scalar GELU uses libm's correctly rounded-ish erf: the two agree to ~3e-7·|x|
        let exact = x.gelu_erf().unwrap().flatten_all().unwrap().to_vec1::<f32>().unwrap();
        let inputs = x.flatten_all().unwrap().to_vec1::<f32>().unwrap();
        for ((a, b), x) in ours.iter().zip(&exact).zip(&inputs) {
            assert!((a - b).abs() <= 5e-7 * x.abs().max(1.0), "gelu({x}) = {a}, exact {b}");
        }
        // a strided input goes through `contiguous` first
        let t = gelu_erf(&x.t().unwrap()).unwrap();
        assert_eq!(t.dims(), &[50_001, 3]);
        assert_eq!(t.t().unwrap().flatten_all().unwrap().to_vec1::<f32>().unwrap(), ours);
    }
}

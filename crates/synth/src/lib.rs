//! splatseg `synth` stage (being written).

//! splatseg `eval` stage (being written).

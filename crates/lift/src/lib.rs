//! splatseg `lift` stage (being written).

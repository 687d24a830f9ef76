//! splatseg `match` stage (being written).

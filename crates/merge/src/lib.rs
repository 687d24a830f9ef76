//! splatseg `merge` stage (being written).

//! splatseg `render` stage (being written).

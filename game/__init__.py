"""Multi-map hard shadows and linear-light soft shadows, measured against a ray tracer."""

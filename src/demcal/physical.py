"""Physical (bench) measurements in, model parameters out."""

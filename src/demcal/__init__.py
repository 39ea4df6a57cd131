"""demcal."""

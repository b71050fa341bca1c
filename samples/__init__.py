"""Sample jobs (APT-CL + geomdl JSON parts) and `make_samples`, the script that builds them."""

"""service: the `kinserve` command line and the HTTP kinematics service."""

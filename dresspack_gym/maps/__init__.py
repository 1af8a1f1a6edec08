"""Maps over robot configurations: robustness of cable configurations (thesis Algorithm 1) and the wear map."""

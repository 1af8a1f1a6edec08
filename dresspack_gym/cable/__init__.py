"""The dresspack: its configuration, where its vertices start, and its MuJoCo discrete elastic rods."""

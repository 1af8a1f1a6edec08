"""Files in and out: station YAML in, robot programs and videos out."""

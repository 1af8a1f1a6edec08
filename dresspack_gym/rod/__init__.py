"""The quasi-static rod engine: discrete elastic rods solved by Newton on their energy, with barrier contact."""

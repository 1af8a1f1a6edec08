"""Cable physics: quasi-static simulation, wear measures and cost, damage, fatigue, trajectory replay, profiles."""

"""Signal processing of recorded drops: preprocessing, 3-to-1 axis reducers, representatives and match metrics."""

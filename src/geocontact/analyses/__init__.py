"""Analyses of the law and the FE on loading histories: cyclic histories and shakedown
(``cycles``), the law under force control (``force_driven``), the material sweeps (``sweeps``),
the paper's loading-history study and findings (``paper_histories``), seismic records on a grain
column (``seismic``)."""

"""Independent references the FE engine is verified against (not part of the engine): the
CalculiX peer model run side by side (``ccx``) and the published fits of sphere-on-flat
elastic-plastic contact (``published_fits``: Kogut & Etsion 2002, Etsion, Kligerman & Kadin
2005, Jackson & Green 2005, Jackson, Chusoipin & Green 2005)."""

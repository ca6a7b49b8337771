"""A hysteresis model (the switched Bouc-Wen, Spencer's, the classic Bouc-Wen, a plug-in) fitted to
force–displacement tests: the study problem ``switched-bouc-wen``, its formulations, a fit and its
result, a fitted model that predicts any record."""

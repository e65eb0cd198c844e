"""The fused localizer (beyond the papers): one particle filter over every kind of tag evidence, WiFi and the
compass, publishing a pose with covariance and ``map -> odom`` as AMCL does (models, measurement, kinds, settings,
tag_map, filter)."""

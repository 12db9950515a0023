// Random vectors for the tests, one component drawn a statement. The arguments of one call are
// evaluated in an order the compiler chooses (gcc: the last first; clang: the first first), so a
// vector built from several draws in one call gave the gcc and the clang build different scenes
// from one seed. These draw in gcc's order, in which the tests' scenes were made.
#pragma once

#include <Eigen/Core>

template <class Distribution, class Engine>
Eigen::Vector3d drawVector3(Distribution& distribution, Engine& engine) {
  const double z = distribution(engine);
  const double y = distribution(engine);
  const double x = distribution(engine);
  return {x, y, z};
}

template <class Distribution, class Engine>
Eigen::Vector2d drawVector2(Distribution& distribution, Engine& engine) {
  const double y = distribution(engine);
  const double x = distribution(engine);
  return {x, y};
}

// Running the product's host in a test as vision_host runs it.
#pragma once

#include <chrono>
#include <thread>

#include "framework_api/host.h"

// Starts the host, runs it until every source has ended, watched as vision_host watches it, and
// stops it. The limit is generous (more under the sanitizers): the loop ends as soon as the sources do.
inline void runUntilSourcesEnd(fw::Host& host, std::chrono::seconds limit = std::chrono::seconds(120)) {
  host.start();
  const auto deadline = std::chrono::steady_clock::now() + limit;
  while (!host.sourcesFinished() && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    host.watch();
  }
  host.stop();
}

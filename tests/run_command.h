// Runs a shell command as a user would, for the tests of the command-line tools.
#pragma once

#include <sys/wait.h>

#include <cstdio>
#include <string>
#include <utility>

// The command's exit status (-1 if it did not exit normally) and its standard output.
inline std::pair<int, std::string> runCommand(const std::string& command) {
  FILE* pipe = popen(command.c_str(), "r");
  std::string out;
  char buffer[4096];
  for (std::size_t n; (n = fread(buffer, 1, sizeof buffer, pipe)) > 0;) out.append(buffer, n);
  const int status = pclose(pipe);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

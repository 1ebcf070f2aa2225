// rbc: multiscale red blood cell mechanics. One executable, one sub-command per job.
#include <CLI/CLI.hpp>
#include <iostream>

int main(int argc, char** argv) {
  CLI::App app{"rbc - multiscale red blood cell membrane mechanics (Hartmann 2008)"};
  app.require_subcommand(1);
  CLI11_PARSE(app, argc, argv);
  return 0;
}

#pragma once
// Asking running pipelines to stop between frames, so that a Ctrl-C or a SIGTERM during a long
// run still leaves every output's summary and the run's reports (runPipeline ends the outputs
// and the commands write the reports). The request is one process-wide flag: a signal handler
// can set nothing else safely.
#include <string>

#include "terramrf/plugin.hpp"

namespace terramrf {

/// Installs SIGINT and SIGTERM handlers that only record the signal (async-signal-safe) and say
/// on stderr that the run is finishing. The first signal puts both back to their default
/// action, so a second one ends the process at once, as it would without the handlers.
void installStopHandlers();

/// What the handlers do: records `signo` (the first request wins; ≤ 0 is ignored). A running
/// runPipeline finishes the frame in hand, takes no other and still ends every output; a stream
/// source waiting for its next frame is interrupted (Source::interrupt()) at once.
void requestStop(int signo) noexcept;

/// The signal of the stop requested (SIGINT, SIGTERM, or what requestStop() was given); 0 if
/// none was.
int stopRequested() noexcept;

/// Forgets a request (tests; a program that goes on after an interrupted run).
void clearStopRequest() noexcept;

/// "SIGINT", "SIGTERM", else "signal N".
std::string signalName(int signo);

/// "interrupted (SIGINT) after 41 of 600 frame(s)" ("after 41 frame(s)" for a stream, whose
/// frames_total is 0), or "" for a run that was not interrupted.
std::string interruptionText(const RunSummary& summary);

}  // namespace terramrf

// Per-test leak checking with the leaks tracer (GST_TRACERS=leaks): its activity
// tracking brackets each test, and an object created during the test that is still
// alive at its end (and not flagged "may be leaked") is a leak.
#pragma once

#include <string>

namespace element_test {

// False when the leaks tracer is not loaded (GST_TRACERS unset): checks are skipped.
bool leakTracerActive();
// Starts (or restarts) tracking: objects created from now on are watched.
void startLeakTracking();
// Stops tracking and describes the objects created since the start that are still
// alive ("GstBuffer 0x..., GstPad 0x..."); empty when there are none.
std::string stopLeakTracking();

} // namespace element_test

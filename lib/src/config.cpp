#include "uavstab/config.hpp"

#include <sstream>
#include <stdexcept>
#include <thread>

#include "uavstab/config_params.hpp"

namespace uavstab {

void StabilizerConfig::validate() const
{
    // Every field against its row in the parameter table (config_params.cpp).
    for (const ConfigParam &p : configParams()) {
        if (p.kind == ParamKind::String) {
            const std::string why = p.checkText(*this);
            if (!why.empty())
                throw std::invalid_argument(std::string("StabilizerConfig: ") + p.name + ": " + why);
            continue;
        }
        const double value = p.get(*this);
        if (!p.accepts(value)) {
            std::ostringstream message;
            message << "StabilizerConfig: " << p.name << " must be " << p.rangeText() << " (got " << value << ")";
            throw std::invalid_argument(message.str());
        }
    }
}

int StabilizerConfig::resolvedThreads() const
{
    if (threads > 0)
        return threads;
    const unsigned n = std::thread::hardware_concurrency();
    return n > 0 ? int(n) : 2;
}

const char *toString(ModelChoice m)
{
    switch (m) {
    case ModelChoice::Rigid:
        return "rigid";
    case ModelChoice::Similarity:
        return "similarity";
    default:
        return "hybrid";
    }
}

const char *toString(PlannerKind p)
{
    switch (p) {
    case PlannerKind::Gaussian:
        return "gaussian";
    case PlannerKind::Box:
        return "box";
    case PlannerKind::L1:
        return "l1";
    default:
        return "optimal";
    }
}

const char *toString(RollingShutter r)
{
    return r == RollingShutter::Off ? "off" : "auto";
}

const char *toString(LensOutput o)
{
    return o == LensOutput::Rectified ? "rectified" : "original";
}

const char *toString(BorderMode b)
{
    return b == BorderMode::Replicate ? "replicate" : "black";
}

} // namespace uavstab

#pragma once
// Nodes that name the same model share one loaded package (one set of ONNX
// sessions, freed with the last node that uses it) and one inference worker
// (a WindowBatcher) that batches their windows, so a crowd costs one worker.
// Packages load on a background thread, reading through the engine's
// FileAccess so paths inside an exported .pck work; the main thread only
// polls.
#include "package.hpp"
#include "window_batcher.hpp"

#include <memory>
#include <mutex>
#include <string>

namespace ardy {

// One model, loading or loaded. Shared by every node that names its path.
class SharedModel {
public:
	// True once loading has ended, well or not (then package() or error()).
	bool is_done() const;
	std::shared_ptr<const ModelPackage> package() const;
	std::string error() const;
	const std::string &path() const { return path_; }
	// The inference worker of this model's planners (made with the package).
	WindowGenerator batched_generator() const;
	WindowBatcherStats batcher_stats() const;

	explicit SharedModel(std::string path) : path_(std::move(path)) {}
	// Frees the package and hands the freed memory back to the system.
	~SharedModel();
	void finish(std::shared_ptr<const ModelPackage> package, std::string error);

private:
	const std::string path_;
	mutable std::mutex mutex_;
	bool done_ = false;
	std::shared_ptr<const ModelPackage> package_;
	std::unique_ptr<WindowBatcher> batcher_;
	std::string error_;
};

// The model at `path` (a res:// or absolute folder with model.json): the one
// already shared when another node holds it, else a new background load.
std::shared_ptr<SharedModel> acquire_model(const std::string &path);

// Models loaded and alive now, for tests and stats.
size_t live_model_count();

// Waits for every background load to end. Called when the extension unloads.
void shut_down_model_loads();

} // namespace ardy

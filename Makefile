# sam build calls build-<Function> with ARTIFACTS_DIR set (BuildMethod: makefile).
# The functions ship the assembler (the Record schema) and the leaderboard packages, with
# dependencies for the Lambda runtime (Python 3.13 on arm64), whatever machine builds them.
# LAMBDA_PLATFORM picks the wheels' platform (bench/bench_functions.py builds a copy for the
# machine it runs on); LAMBDA_PYTHON must be a Python 3.13, the runtime's, to compile the .pyc.
LAMBDA_PLATFORM ?= manylinux2014_aarch64
LAMBDA_PYTHON ?= python3.13
PIP_TARGET_FLAGS = --platform $(LAMBDA_PLATFORM) --implementation cp --python-version 3.13 \
	--only-binary=:all: --upgrade --quiet --no-compile

# The Lambda Python runtime brings these (boto3 and its dependencies): do not ship them twice.
RUNTIME_PROVIDED = boto3 boto3-* botocore botocore-* s3transfer s3transfer-* urllib3 urllib3-* \
	dateutil python_dateutil-* jmespath jmespath-* six.py six-*

# Never used at run time: Powertools' Swagger UI assets (the functions never call
# enable_swagger), regex's own tests, pydantic's v1 API.
UNUSED = aws_lambda_powertools/event_handler/openapi/swagger_ui/*.js \
	aws_lambda_powertools/event_handler/openapi/swagger_ui/*.css regex/tests pydantic/v1

# What one function never imports, left out of its bundle: the pull function checks no name (the
# name checks' regex and disarm), the others draw no page (Jinja2, MarkupSafe, segno).
# tests/unit/test_function_imports.py answers each function's events without them.
PAGES = jinja2 jinja2-* markupsafe markupsafe-* MarkupSafe-* segno segno-*
NOT_SHIPPED_PullFunction = regex regex-* disarm disarm-*
NOT_SHIPPED_PushFunction = $(PAGES)
NOT_SHIPPED_AdminFunction = $(PAGES)
NOT_SHIPPED_NotifyFunction = $(PAGES)
NOT_SHIPPED_CardFunction = regex regex-* disarm disarm-*

# Lambda's file system is read-only: a module shipped without its .pyc is compiled again at every
# cold start (~300-400 ms for these functions). Compiled here with the runtime's Python, as
# checked-hash .pyc (valid whatever the files' times after zipping; a changed source is still
# noticed). Only what the functions import: the rest of Powertools' utilities,
# pydantic.experimental and pydantic's mypy plugin stay source-only, which keeps the bundle small.
# bench/bench_functions.py counts the modules a cold start still compiles (should be none).
PRECOMPILED = drboard_assembler drboard_functions segno regex disarm jinja2 markupsafe typing_extensions.py annotated_types \
	typing_inspection pydantic pydantic_core aws_lambda_powertools/*.py \
	aws_lambda_powertools/event_handler aws_lambda_powertools/exceptions \
	aws_lambda_powertools/logging aws_lambda_powertools/metrics \
	aws_lambda_powertools/middleware_factory aws_lambda_powertools/shared \
	aws_lambda_powertools/tracing aws_lambda_powertools/warnings \
	aws_lambda_powertools/utilities/__init__.py aws_lambda_powertools/utilities/data_classes \
	aws_lambda_powertools/utilities/batch \
	aws_lambda_powertools/utilities/jmespath_utils aws_lambda_powertools/utilities/typing
NOT_PRECOMPILED = (^|/)pydantic/(experimental/|mypy\.py)

# One recipe for every function: $(1) is the extra lock it installs (the CardFunction's
# renderer), $(2) what it leaves out (the card fonts, but in the CardFunction), $(3) what else it
# compiles ahead of time.
define build_function
	@$(LAMBDA_PYTHON) -c 'import sys; sys.exit(sys.version_info[:2] != (3, 13))' || { \
		echo "LAMBDA_PYTHON=$(LAMBDA_PYTHON) is not Python 3.13, the runtime's: the .pyc would" \
		"not load. Put python3.13 on PATH or pass LAMBDA_PYTHON=/path/to/python3.13." >&2; exit 1; }
	python3 -m pip install $(PIP_TARGET_FLAGS) --no-deps --target "$(ARTIFACTS_DIR)" \
		-r functions/requirements.lock $(addprefix -r ,$(1))
	cd "$(ARTIFACTS_DIR)" && rm -rf $(RUNTIME_PROVIDED) $(UNUSED) $(NOT_SHIPPED_$(@:build-%=%))
	cp -R assembler/drboard_assembler functions/drboard_functions "$(ARTIFACTS_DIR)/"
	cd "$(ARTIFACTS_DIR)" && rm -rf bin *-stubs $(2)
	find "$(ARTIFACTS_DIR)" \( -name "__pycache__" -o -name "*.pyi" \) -prune -exec rm -rf {} +
	rm -rf "$(ARTIFACTS_DIR)"/*.dist-info/RECORD
	cd "$(ARTIFACTS_DIR)" && $(LAMBDA_PYTHON) -m compileall -q -j 0 --invalidation-mode checked-hash \
		-x '$(NOT_PRECOMPILED)' $$(ls -d $(PRECOMPILED) 2>/dev/null) $(3)
endef

# The card fonts (0.8 MB) ship with the CardFunction only, which draws the cards.
CARD_FONTS = drboard_functions/cards/fonts

build-PushFunction build-PullFunction build-AdminFunction build-NotifyFunction:
	$(call build_function,,$(CARD_FONTS))

# The CardFunction adds the renderer (resvg, functions/card-requirements.lock) and keeps the fonts.
build-CardFunction:
	$(call build_function,functions/card-requirements.lock,,resvg_py)

# functions/requirements.lock pins every package the functions ship (functions/requirements.txt
# resolved for the runtime, less what the runtime brings), functions/card-requirements.lock what
# the CardFunction adds. Run after changing either list.
lock:
	python3 -m pip install --quiet uv
	python3 -m uv pip compile functions/requirements.txt --python-version 3.13 \
		--python-platform aarch64-manylinux_2_17 --no-annotate --custom-compile-command "make lock" \
		$(addprefix --no-emit-package ,boto3 botocore s3transfer urllib3 python-dateutil jmespath six) \
		--output-file functions/requirements.lock
	python3 -m uv pip compile functions/card-requirements.txt --python-version 3.13 \
		--python-platform aarch64-manylinux_2_17 --no-annotate --custom-compile-command "make lock" \
		--constraint functions/requirements.lock --output-file functions/card-requirements.lock

.PHONY: lock

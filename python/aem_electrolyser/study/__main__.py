from aem_electrolyser.commands import study

study()
